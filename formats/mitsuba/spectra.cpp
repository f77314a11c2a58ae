// Colour parameters: every spectrum and colour notation of Mitsuba 0.5's scene format, converted to
// linear RGB as Mitsuba's RGB build does (its scene handler, SceneHandler::endElement, and
// libcore/spectrum.cpp; read, not copied):
//
//   <spectrum value="0.5"/>              one number: that value in R, G and B (an `intent` is allowed and,
//                                         in the RGB build, changes nothing: its D65 white is (1, 1, 1))
//   <spectrum value="0.1, 0.2, 0.3"/>    three numbers: R, G, B (the RGB build has three "samples")
//   <spectrum value="400:0.1, 500:0.5"/> nm:value pairs, zero-extended and integrated against the CIE
//                                         tables (libcommon/spectrum.h), interpolated as the setting
//                                         spectrum-interpolation says
//   <spectrum filename="x.spd"/>         the same pairs from a file: "nm value" per line, '#' comments
//   <rgb value="0.1, 0.2, 0.3"/>         linear RGB, one or three numbers or "#rrggbb" (bytes / 255, no
//                                         sRGB decoding -- as Mitsuba); `intent` as for <spectrum>
//   <srgb value="#6d7185"/>              sRGB-encoded, one or three numbers or "#rrggbb"
//   <blackbody temperature="6500K" scale="1e-4"/>  Planck's law (W m^-2 sr^-1 nm^-1) times scale
//
// Mitsuba 0.5 has no other colour element (no <hsv>: it is an unknown element, as there).
#include <cctype>
#include <charconv>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "formats/mitsuba/xml.h"
#include "libcommon/spectrum.h"

namespace iris::mitsuba {
namespace {

// "#rrggbb" -> the three bytes / 255; nullopt if `v` is not of that form.
std::optional<RGB> hex_colour(const std::string& v) {
    if (v.size() != 7 || v[0] != '#') return std::nullopt;
    RGB c;
    for (int i = 0; i < 3; ++i) {
        unsigned byte = 0;
        auto [ptr, ec] = std::from_chars(v.data() + 1 + 2 * i, v.data() + 3 + 2 * i, byte, 16);
        if (ec != std::errc() || ptr != v.data() + 3 + 2 * i) return std::nullopt;
        c[i] = float(byte) / 255.0f;
    }
    return c;
}

}  // namespace

std::optional<RGB> XmlReader::get_spectrum(Plugin& p, const std::string& name) {
    Prop* prop = find(p, name);
    if (!prop) return std::nullopt;
    prop->used = true;
    const Source& src = *p.src;
    const int line = prop->line;
    const std::string w = what(p, *prop);
    const pugi::xml_node n = prop->node;
    // Mitsuba's `intent` (reflectance or illuminant): checked, then without effect in an RGB build.
    auto check_intent = [&]() {
        if (auto intent = opt_attr(src, n, "intent")) {
            const std::string i = lower(*intent);
            if (i != "reflectance" && i != "illuminant")
                fail(src, line, w + ": intent must be reflectance or illuminant, not " + quote(*intent));
        }
    };
    // Tabulated samples -> RGB with the scene's interpolation; `where` names them in messages.
    auto tabulated = [&](const std::vector<float>& wl, const std::vector<float>& val, const std::string& where) {
        interpolated_spectrum = true;
        try {
            return spectrum_to_rgb(wl, val, options_.spectrum_interpolation);
        } catch (const std::invalid_argument& e) {
            fail(src, line, w + where + ": " + e.what());
        }
    };
    switch (prop->kind) {
        case Kind::Spectrum: {
            check_attrs(src, n, {"name", "value", "filename", "intent"});
            check_no_text(src, n);
            const bool has_value = bool(n.attribute("value")), has_file = bool(n.attribute("filename"));
            if (has_value == has_file) fail(src, line, w + ": a <spectrum> needs either value or filename");
            if (has_file) {
                if (n.attribute("intent")) fail(src, line, w + ": a <spectrum> from a file takes no intent");
                const std::string file = attr(src, n, "filename");
                const fs::path path = resolve(src, file);
                std::string text;
                if (!read_file(path, &text)) fail(src, line, w + ": cannot read spectrum file " + quote(file));
                fingerprint.add(text);
                // As Mitsuba's InterpolatedSpectrum(path): "nm value" per line; blank lines and lines
                // starting with '#' are skipped; the first line that is not two numbers ends the data.
                std::vector<float> wl, val;
                std::istringstream in(text);
                for (std::string l; std::getline(in, l);) {
                    const size_t first = l.find_first_not_of(" \t\r");
                    if (first == std::string::npos || l[first] == '#') continue;
                    std::istringstream ls(l);
                    double a = 0, b = 0;
                    if (!(ls >> a >> b)) break;
                    wl.push_back(float(a));
                    val.push_back(float(b));
                }
                if (wl.empty()) fail(src, line, w + ": no \"wavelength value\" lines in spectrum file " + quote(file));
                return tabulated(wl, val, " (file " + quote(file) + ")");
            }
            std::string v = attr(src, n, "value");
            std::vector<std::string_view> t = tokens(v);
            if (!t.empty() && t[0].find(':') != std::string_view::npos) {
                if (n.attribute("intent")) fail(src, line, w + ": intent is for a single value, not nm:value pairs");
                std::vector<float> wl, val;
                for (std::string_view tok : t) {
                    size_t c = tok.find(':');
                    if (c == std::string_view::npos || tok.find(':', c + 1) != std::string_view::npos)
                        fail(src, line, w + ": bad wavelength:value pair " + quote(tok));
                    wl.push_back(parse_float(src, line, tok.substr(0, c), w));
                    val.push_back(parse_float(src, line, tok.substr(c + 1), w));
                }
                return tabulated(wl, val, "");
            }
            // One number: the same value in every channel (measured with Mitsuba: value="1"
            // renders as (1,1,1)). Three numbers: RGB, as Mitsuba's RGB build reads them.
            if (t.size() == 1) {
                check_intent();
                return RGB(parse_float(src, line, t[0], w));
            }
            if (n.attribute("intent")) fail(src, line, w + ": intent is for a single value");
            if (t.size() == 3)
                return RGB(parse_float(src, line, t[0], w), parse_float(src, line, t[1], w),
                           parse_float(src, line, t[2], w));
            fail(src, line, w + ": a <spectrum> value is one number, three numbers or nm:value pairs, not " + quote(v));
        }
        case Kind::Rgb: {
            check_attrs(src, n, {"name", "value", "intent"});
            check_no_text(src, n);
            check_intent();
            const std::string v = attr(src, n, "value");
            if (!v.empty() && v[0] == '#') {
                if (auto c = hex_colour(v)) return *c;  // linear bytes / 255, as Mitsuba's <rgb>
                fail(src, line, w + ": bad colour " + quote(v) + " (expected #rrggbb)");
            }
            std::vector<float> f = parse_floats(src, line, v, w);
            if (f.size() == 1) return RGB(f[0]);
            if (f.size() == 3) return RGB(f[0], f[1], f[2]);
            fail(src, line, w + ": an <rgb> value is one or three numbers (or #rrggbb)");
        }
        case Kind::Srgb: {
            std::string v = value_of(p, *prop);
            RGB c;
            if (!v.empty() && v[0] == '#') {
                auto h = hex_colour(v);
                if (!h) fail(src, line, w + ": bad colour " + quote(v) + " (expected #rrggbb)");
                c = *h;
            } else {
                std::vector<float> f = parse_floats(src, line, v, w);
                if (f.size() == 1) c = RGB(f[0]);
                else if (f.size() == 3) c = RGB(f[0], f[1], f[2]);
                else fail(src, line, w + ": an <srgb> value is #rrggbb, one or three numbers");
            }
            return RGB(srgb_to_linear(c.r), srgb_to_linear(c.g), srgb_to_linear(c.b));
        }
        case Kind::Blackbody: {
            check_attrs(src, n, {"name", "temperature", "scale"});
            check_no_text(src, n);
            // Mitsuba strips one trailing 'K' (or 'k'): temperature="6500K" is 6500 kelvins.
            std::string temp = attr(src, n, "temperature");
            while (!temp.empty() && std::isspace(static_cast<unsigned char>(temp.back()))) temp.pop_back();
            if (!temp.empty() && (temp.back() == 'K' || temp.back() == 'k')) temp.pop_back();
            const float kelvin = parse_float(src, line, temp, w + " (temperature)");
            if (!(kelvin > 0))
                fail(src, line, w + ": the black body's temperature must be positive (kelvins), not " + quote(temp));
            float scale = 1.0f;
            if (auto s = opt_attr(src, n, "scale")) scale = parse_float(src, line, *s, w + " (scale)");
            if (!(scale >= 0)) fail(src, line, w + ": the black body's scale must not be negative");
            interpolated_spectrum = true;
            const RGB c = blackbody_to_rgb(kelvin, options_.spectrum_interpolation) * scale;
            if (!is_finite(c)) fail(src, line, w + ": the black body's radiance times scale overflows");
            return c;
        }
        default: wrong_kind(p, *prop, "a <spectrum>, <rgb>, <srgb> or <blackbody>");
    }
}

RGB XmlReader::get_spectrum(Plugin& p, const std::string& name, RGB def) { return get_spectrum(p, name).value_or(def); }

}  // namespace iris::mitsuba
