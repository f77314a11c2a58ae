// The <scene> root: the elements it may hold, <include>, <medium>; and the public entry points
// load_scene / parse_scene (formats/scene_xml.h). Each plugin kind is built in its own file (builder.h).
#include <new>

#include "formats/mitsuba/builder.h"

namespace iris::mitsuba {

Scene SceneBuilder::run(const std::string& path) {
    const Source& src = open_source(path, nullptr, 0, fs::path());
    pugi::xml_node root = src.doc.document_element();
    if (std::string_view(root.name()) != "scene")
        fail(src, src.line_of(root), "the root element is <" + std::string(root.name()) + ">, expected <scene>");
    check_attrs(src, root, {"version"});
    // Mitsuba 2 and 3 (version 2.x, 3.x) changed names and defaults (e.g. lowercase lookat, Cartesian
    // RGB handling): reading their files as 0.x would render something silently different.
    if (pugi::xml_attribute v = root.attribute("version"); v && std::string_view(v.value()).substr(0, 2) != "0.")
        fail(src, src.line_of(root),
             "scene version " + quote(v.value()) + " is not supported (iris reads the Mitsuba 0.5/0.6 format, version 0.x)");

    // Parameters: <default> gives the fallback, the caller's values win.
    collect_defaults(src, root);
    for (const auto& [k, v] : options_.parameters) set_parameter(k, v);

    process_scene(src, root);

    if (!have_sensor) fail(src, src.line_of(root), "the scene has no <sensor> (iris needs a perspective camera)");
    for (const auto& [id, nb] : named_bsdfs)
        if (!nb.used)
            warn(*nb.src, nb.line, "bsdf " + quote(id) + " is never referenced");
    for (const auto& [id, nt] : named_textures)
        if (!nt.used)
            warn(*nt.src, nt.line, "texture " + quote(id) + " is never referenced");
    for (const auto& [id, u] : unbuilt)
        warn(*u.src, u.line, "unsupported plugin " + quote(u.type) + " (" + u.tag + " " + quote(id) +
                                 ") ignored: nothing refers to it");
    for (const Unbuilt& u : unbuilt_anonymous)
        warn(*u.src, u.line, "unsupported plugin " + quote(u.type) + " (" + u.tag + " without an id) ignored: nothing can refer to it");
    for (const IgnoredMedium& m : media)
        warn(*m.src, m.line, m.label + " ignored: iris renders no participating media, and no shape refers to it");
    if (scene.lights.empty()) warn(src, src.line_of(root), "the scene has no emitters; it will render black");

    // The parameter overrides change the scene, so they are part of its identity; so does the
    // spectrum interpolation where a spectrum depends on it (a scene without one keeps its identity).
    for (const auto& [k, v] : options_.parameters) fingerprint.add(k + "=" + v);
    if (interpolated_spectrum)
        fingerprint.add(options_.spectrum_interpolation == SpectrumInterpolation::Linear
                            ? "spectrum-interpolation=linear"
                            : "spectrum-interpolation=mitsuba-0.5.0");
    scene.source = path;
    scene.fingerprint = fingerprint.hex();
    return std::move(scene);
}

void SceneBuilder::process_scene(const Source& src, pugi::xml_node root) {
    check_no_text(src, root);
    for (pugi::xml_node c : root.children()) {
        if (c.type() != pugi::node_element) continue;
        const std::string tag = c.name();
        if (tag == "default") continue;  // collected before
        if (tag == "include") include(src, c);
        else if (tag == "integrator") integrator(src, c);
        else if (tag == "sensor") sensor(src, c);
        else if (tag == "bsdf") {
            if (!defer_unsupported(src, c, bsdf_type_supported)) top_level_bsdf(src, c);
        } else if (tag == "texture") {
            if (!defer_unsupported(src, c, texture_type_supported)) top_level_texture(src, c);
        }
        else if (tag == "shape") shape(src, c);
        else if (tag == "emitter") emitter(src, c);
        else if (tag == "medium") medium(src, c);
        else if (tag == "alias" || tag == "null" || tag == "phase" || tag == "subsurface")
            fail(src, src.line_of(c), "<" + tag + "> is not supported by iris");
        else fail(src, src.line_of(c), "unknown element <" + tag + "> in <scene>");
    }
}

void SceneBuilder::include(const Source& src, pugi::xml_node n) {
    check_attrs(src, n, {"filename"});
    check_no_text(src, n);
    const int line = src.line_of(n);
    if (++include_depth > 16) fail(src, line, "<include> nested more than 16 deep (a cycle?)");
    std::string file = attr(src, n, "filename");
    const fs::path resolved = resolve(src, file);
    const Source& inc = open_source(resolved.string(), &src, line, resolved);
    pugi::xml_node root = inc.doc.document_element();
    if (std::string_view(root.name()) != "scene")
        fail(inc, inc.line_of(root), "an included file must have <scene> as its root element");
    check_attrs(inc, root, {"version"});
    collect_defaults(inc, root);
    process_scene(inc, root);
    --include_depth;
}

void SceneBuilder::medium(const Source& src, pugi::xml_node n) {
    check_attrs(src, n, {"type", "id", "name"});
    const int line = src.line_of(n);
    std::string id = opt_attr(src, n, "id").value_or("");
    register_id(src, line, id, "medium");
    std::string label = "medium";
    if (!id.empty()) label.append(" ").append(quote(id));
    // Warned about at the end: a shape that refers to it fails first (medium_ref), and the warning
    // would contradict that error.
    media.push_back({&src, line, label});
}

bool SceneBuilder::defer_unsupported(const Source& src, pugi::xml_node n, bool (*supported)(const std::string&)) {
    const std::string type = attr(src, n, "type");
    if (supported(type)) return false;
    check_attrs(src, n, {"type", "id", "name"});
    Unbuilt u{n.name(), type, &src, src.line_of(n)};
    const std::string id = opt_attr(src, n, "id").value_or("");
    register_id(src, u.line, id, u.tag);
    if (id.empty()) unbuilt_anonymous.push_back(u);
    else unbuilt[id] = u;
    return true;
}

void SceneBuilder::check_not_unbuilt(const Source& src, int line, const std::string& id) const {
    auto it = unbuilt.find(id);
    if (it == unbuilt.end()) return;
    const Unbuilt& u = it->second;
    fail(src, line, "<ref id=" + quote(id) + "> refers to unsupported plugin " + quote(u.type) + " (" + u.tag + " at " +
                        u.src->path + ":" + std::to_string(u.line) + ")");
}

void SceneBuilder::medium_ref(const Source& src, pugi::xml_node n, const std::string& side) const {
    const int line = src.line_of(n);
    const std::string id = opt_attr(src, n, "id").value_or("");
    const IdInfo* known = id_info(id);
    if (known && known->tag != "medium")
        fail(src, line, "<ref name=" + quote(side) + " id=" + quote(id) + "> refers to a <" + known->tag +
                            ">; a shape's " + side + " is a medium");
    fail(src, line, "the shape's " + side + " medium " + quote(id) +
                        (known ? " (" + known->file + ":" + std::to_string(known->line) + ")" : std::string()) +
                        ": participating media are not supported yet");
}

std::string name_list(const std::vector<std::string>& names, const char* last_separator) {
    std::string out;
    for (size_t i = 0; i < names.size(); ++i) {
        if (i > 0) out += i + 1 == names.size() ? last_separator : ", ";
        out += names[i];
    }
    return out;
}

}  // namespace iris::mitsuba

namespace iris {

Scene parse_scene(const std::string& path, const SceneLoadOptions& options) { return mitsuba::SceneBuilder(options).run(path); }

Scene load_scene(const std::string& path, const SceneLoadOptions& options) {
    Scene scene = parse_scene(path, options);
    // finalize() reports problems the parser cannot see element by element with libcommon's own
    // exceptions: a light whose area or power overflows float (a rectangle scaled by 1e20, a radiance
    // of 3e38) made Distribution1D throw std::invalid_argument and lights_prepare std::runtime_error,
    // which escaped as messages without the file name (tests/data/fuzz-regressions/scene_xml/).
    // The contract is SceneError naming the file.
    try {
        scene.finalize();
    } catch (const std::bad_alloc&) {
        throw;
    } catch (const std::exception& e) {
        throw SceneError(path + ": " + e.what());
    }
    return scene;
}

}  // namespace iris
