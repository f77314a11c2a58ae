#include "tools/merge/merge.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>

#include "libcommon/film.h"
#include "formats/film_parts.h"
#include "tools/common/settings.h"
#include "tools/common/tool_util.h"

namespace iris {

namespace {

std::string num(double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return buf;
}

std::string range_text(uint64_t a, uint64_t b) { return std::to_string(a) + ":" + std::to_string(b); }

// "A:B" -> [A, B); throws naming the file.
PartRange parse_range(const std::string& text, const std::string& path) {
    uint64_t a = 0, b = 0;
    if (!iris::parse_range(text, &a, &b))
        throw MergeError(path + ": damaged range '" + text + "'");
    return {a, b, path};
}

uint64_t parse_count(const std::map<std::string, std::string>& md, const char* key, const std::string& path) {
    auto it = md.find(key);
    if (it == md.end()) throw MergeError(path + ": metadata '" + key + "' missing");
    char* end = nullptr;
    const unsigned long long v = std::strtoull(it->second.c_str(), &end, 10);
    if (it->second.empty() || *end != 0 || it->second[0] == '-') throw MergeError(path + ": metadata '" + key + "' is not a count");
    return v;
}

double parse_seconds(const std::map<std::string, std::string>& md, const char* key) {
    auto it = md.find(key);
    return it == md.end() ? 0.0 : std::atof(it->second.c_str());
}

// The first "; "-separated item in which two settings strings differ.
std::string first_difference(const std::string& a, const std::string& b) {
    size_t i = 0;
    while (i < a.size() && i < b.size() && a[i] == b[i]) ++i;
    auto item = [&](const std::string& s) {
        size_t from = s.rfind("; ", i);
        from = from == std::string::npos ? 0 : from + 2;
        size_t to = s.find("; ", i);
        return s.substr(from, to == std::string::npos ? std::string::npos : to - from);
    };
    std::string out = "'";
    out += item(b);
    out += "' against '";
    out += item(a);
    out += "'";
    return out;
}

}  // namespace

void check_ranges(std::vector<PartRange> parts, uint64_t total, const char* what) {
    std::sort(parts.begin(), parts.end(), [](const PartRange& a, const PartRange& b) { return a.begin < b.begin; });
    uint64_t covered = 0;
    for (size_t i = 0; i < parts.size(); ++i) {
        const PartRange& p = parts[i];
        if (p.end > total)
            throw MergeError(p.path + ": " + what + " " + range_text(p.begin, p.end) + " reach beyond the " +
                             std::to_string(total) + " of the render");
        if (i > 0 && p.begin < covered)
            throw MergeError(parts[i - 1].path + " and " + p.path + " overlap: both hold " + what + " " +
                             range_text(p.begin, std::min(covered, p.end)));
        if (p.begin > covered)
            throw MergeError(std::string(what) + " " + range_text(covered, p.begin) + " missing: no part holds them (of " +
                             std::to_string(total) + ")");
        covered = p.end;
    }
    if (covered < total)
        throw MergeError(std::string(what) + " " + range_text(covered, total) + " missing: no part holds them (of " +
                         std::to_string(total) + ")");
}

Image merge_image_parts(const std::vector<std::string>& paths, const std::string& command_line) {
    if (paths.empty()) throw MergeError("no parts given");
    std::vector<Image> parts;
    std::vector<PartRange> ranges;
    parts.reserve(paths.size());
    for (const std::string& path : paths) {
        Image img = read_exr(path);
        auto& md = img.metadata;
        if (!md.count("iris:sample_range") || !has_film_parts(img))
            throw MergeError(path + ": not a part of a render (render --sample-range A:B writes one)");
        ranges.push_back(parse_range(md["iris:sample_range"], path));
        if (!parts.empty()) {
            const Image& ref = parts.front();
            const std::string& p0 = paths.front();
            if (md["iris:scene_fingerprint"] != ref.metadata.at("iris:scene_fingerprint"))
                throw MergeError(path + ": rendered from another scene than " + p0 + " (scene fingerprint " +
                                 md["iris:scene_fingerprint"] + ", not " + ref.metadata.at("iris:scene_fingerprint") + ")");
            // The settings record (render's --set, resolved): the first setting that differs by name.
            const std::string diff = settings_difference(ref.metadata.at("iris:settings"), md["iris:settings"]);
            if (!diff.empty()) throw MergeError(path + ": rendered with other settings than " + p0 + ": " + diff);
            for (const char* key : {"iris:sample_settings", "iris:variance_layer", "iris:samples_layer", "iris:spp_total"})
                if (md[key] != ref.metadata.at(key))
                    throw MergeError(path + ": rendered with other settings than " + p0 + ": " +
                                     first_difference(ref.metadata.at(key), md[key]));
        } else {
            for (const char* key : {"iris:scene_fingerprint", "iris:settings", "iris:sample_settings", "iris:variance_layer",
                                    "iris:samples_layer",
                                    "iris:spp_total", "iris:light_paths_per_sample"})
                if (!md.count(key)) throw MergeError(path + ": metadata '" + key + "' missing");
        }
        // A part is complete or absent: its sample count must be its range's in every pixel.
        const int ci = img.channel_index("part.count");
        const float want = float(ranges.back().end - ranges.back().begin);
        for (float c : img.data[size_t(ci)])
            if (c != want)
                throw MergeError(path + ": holds " + std::to_string(c) + " samples in a pixel, not the " +
                                 std::to_string(int64_t(want)) + " of its range " + md["iris:sample_range"] + " (a partial part)");
        parts.push_back(std::move(img));
    }
    const auto& md0 = parts.front().metadata;
    const uint64_t total = parse_count(md0, "iris:spp_total", paths.front());
    check_ranges(ranges, total, "samples");

    Film film(parts.front().width, parts.front().height);
    const uint64_t lps = parse_count(md0, "iris:light_paths_per_sample", paths.front());
    if (lps > 0) film.enable_light(double(lps));
    for (size_t k = 0; k < parts.size(); ++k) accumulate_film_parts(parts[k], paths[k], film);

    Image out;
    add_film_layers(out, film, md0.at("iris:variance_layer") == "1", md0.at("iris:samples_layer") == "1");
    out.metadata = md0;
    for (const char* key : {"iris:sample_range", "iris:spp_total", "iris:light_paths_per_sample", "iris:variance_layer",
                            "iris:samples_layer"})
        out.metadata.erase(key);
    // Counters add; the time is the parts' summed sampling time (CPU-parallel wall seconds of each).
    double seconds = 0;
    uint64_t nonfinite = 0, rays = 0, lookups = 0, light_paths = 0;
    std::string list;
    for (size_t k = 0; k < parts.size(); ++k) {
        const auto& md = parts[k].metadata;
        seconds += parse_seconds(md, "iris:seconds");
        nonfinite += parse_count(md, "iris:nonfinite_samples", paths[k]);
        rays += parse_count(md, "iris:rays", paths[k]);
        lookups += parse_count(md, "iris:cache_lookups", paths[k]);
        light_paths += parse_count(md, "iris:light_paths", paths[k]);
        if (k) list += " ";
        list += paths[k] + "=" + md.at("iris:sample_range");
    }
    out.metadata["iris:spp"] = std::to_string(total);
    out.metadata["iris:seconds"] = std::to_string(seconds);
    out.metadata["iris:nonfinite_samples"] = std::to_string(nonfinite);
    out.metadata["iris:rays"] = std::to_string(rays);
    out.metadata["iris:cache_lookups"] = std::to_string(lookups);
    out.metadata["iris:light_paths"] = std::to_string(light_paths);
    out.metadata["iris:merged"] = std::to_string(parts.size()) + " parts by `" + command_line + "`: " + list;
    return out;
}

MergedPhotons merge_photon_parts(const std::vector<std::string>& paths, const std::string& command_line) {
    if (paths.empty()) throw MergeError("no parts given");
    // Parameters that are the part's own, not the map's settings.
    auto own = [](const std::string& name) {
        return name == "seconds" || name == "nonfinite_discarded" || name == "caustic_share" || name == "path_begin" ||
               name == "path_end";
    };
    std::vector<PhotonMapFile> parts;
    std::vector<PartRange> ranges;
    for (const std::string& path : paths) {
        PhotonMapFile f = read_photon_map(path);
        const auto& pp = f.header.provenance.parameters;
        if (!pp.count("path_total") || !pp.count("path_begin") || !pp.count("path_end"))
            throw MergeError(path + ": not a part of a photon map (trace-photons --path-range A:B writes one)");
        if (!(pp.at("path_begin") >= 0 && pp.at("path_begin") < pp.at("path_end")))
            throw MergeError(path + ": damaged path range");
        ranges.push_back({uint64_t(pp.at("path_begin")), uint64_t(pp.at("path_end")), path});
        if (!parts.empty()) {
            const PhotonMapFile& ref = parts.front();
            const std::string& p0 = paths.front();
            if (f.header.scene_fingerprint != ref.header.scene_fingerprint)
                throw MergeError(path + ": traced in another scene than " + p0 + " (scene fingerprint " +
                                 f.header.scene_fingerprint + ", not " + ref.header.scene_fingerprint + ")");
            const auto& rp = ref.header.provenance.parameters;
            if (f.header.provenance.seed != ref.header.provenance.seed)
                throw MergeError(path + ": traced with another seed than " + p0 + " (" +
                                 std::to_string(f.header.provenance.seed) + ", not " +
                                 std::to_string(ref.header.provenance.seed) + ")");
            for (const auto& [name, value] : rp) {
                if (own(name)) continue;
                auto it = pp.find(name);
                if (it == pp.end() || it->second != value)
                    throw MergeError(path + ": traced with other settings than " + p0 + ": " + name + " " +
                                     (it == pp.end() ? std::string("missing") : num(it->second)) + ", not " + num(value));
            }
            for (const auto& [name, value] : pp)
                if (!own(name) && !rp.count(name))
                    throw MergeError(path + ": traced with other settings than " + p0 + ": " + name + " given");
            if (f.photons.emitted_paths != ref.photons.emitted_paths || f.photons.max_depth != ref.photons.max_depth ||
                f.photons.bounces.empty() != ref.photons.bounces.empty() ||
                f.photons.caustic.empty() != ref.photons.caustic.empty())
                throw MergeError(path + ": traced with other settings than " + p0 + " (emitted paths, depth or datasets differ)");
        }
        parts.push_back(std::move(f));
    }
    const auto& p0 = parts.front().header.provenance;
    check_ranges(ranges, uint64_t(p0.parameters.at("path_total")), "paths");
    std::vector<size_t> order(parts.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return ranges[a].begin < ranges[b].begin; });

    MergedPhotons out;
    out.scene_fingerprint = parts.front().header.scene_fingerprint;
    PhotonMap& m = out.photons;
    m.emitted_paths = parts.front().photons.emitted_paths;
    m.max_depth = parts.front().photons.max_depth;
    size_t n = 0;
    for (const auto& p : parts) n += p.photons.size();
    m.position.reserve(n);
    m.direction.reserve(n);
    m.power.reserve(n);
    m.normal.reserve(n);
    double seconds = 0, nonfinite = 0;
    for (size_t i : order) {
        PhotonMap& p = parts[i].photons;
        auto append = [](auto& to, const auto& from) { to.insert(to.end(), from.begin(), from.end()); };
        append(m.position, p.position);
        append(m.direction, p.direction);
        append(m.power, p.power);
        append(m.normal, p.normal);
        append(m.bounces, p.bounces);
        append(m.caustic, p.caustic);
        const auto& pp = parts[i].header.provenance.parameters;
        if (pp.count("seconds")) seconds += pp.at("seconds");
        if (pp.count("nonfinite_discarded")) nonfinite += pp.at("nonfinite_discarded");
        PhotonMap().position.swap(p.position);  // (frees the part as it goes)
    }
    out.provenance = p0;
    out.provenance.command_line = command_line;
    out.provenance.inputs = parts.front().header.provenance.inputs;
    for (const char* own_name : {"path_begin", "path_end", "path_total"}) out.provenance.parameters.erase(own_name);
    out.provenance.parameters["seconds"] = seconds;
    out.provenance.parameters["nonfinite_discarded"] = nonfinite;
    out.provenance.parameters["caustic_share"] = caustic_power_share(m);
    out.provenance.parameters["merged_parts"] = double(parts.size());
    return out;
}

}  // namespace iris
