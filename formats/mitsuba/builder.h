// The builders of the Mitsuba scene reader: one file per plugin kind turns parsed plugin elements
// (xml.h) into the Scene's arrays.
//
//   scene.cpp     the <scene> root, <include>, <medium>; load_scene / parse_scene
//   sensor.cpp    <integrator>, <sensor>, <film> with its <rfilter>, <sampler>
//   bsdfs.cpp     <bsdf> plugins, <ref>s to them
//   textures.cpp  <texture> plugins (textured BSDF parameters), <ref>s to them
//   shapes.cpp    <shape> plugins and the area emitter a shape carries
//   meshes.cpp    mesh files (OBJ, PLY, serialized) to world-space Meshes; shapegroups and instances
//   emitters.cpp  <emitter> plugins
//
// Adding a plugin: write one function in the file of its kind, with the signature of that kind's
// table (BsdfBuilder, TextureBuilder, ShapeBuilder -- or MeshBuilder wrapped in mesh_shape<> for a
// mesh -- and EmitterBuilder, each in its file), and add one row {"name", function} to the table
// there (kBsdfs, kTextures, kShapes, kEmitters). The function queries its parameters from the Plugin
// with the XmlReader getters (b.get_float(p, "name", default), ...), with Mitsuba's names and
// defaults; the dispatcher then calls finish(), which warns about every parameter the function did not
// query (rejects it with SceneLoadOptions::strict). Then add its test (tests/unit/test_scene_loader.cpp
// or a file beside it) and a line in DESIGN.md's list of supported plugins. formats/README.md says the
// same.
#pragma once

#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "formats/mitsuba/xml.h"

namespace iris::mitsuba {

// A BSDF declared with an id, for later <ref>s.
struct NamedBsdf {
    Bsdf bsdf;
    const Source* src = nullptr;
    int line = 0;
    int index = -1;  // in scene.bsdfs once a shape uses it
    bool used = false;
};

// A texture declared with an id, for later <ref>s.
struct NamedTexture {
    int16_t index = -1;
    const Source* src = nullptr;
    int line = 0;
    bool used = false;
};

// A top-level plugin iris cannot build (a BSDF or texture type it does not read), kept by its id: an
// error once something refers to it, a warning at the end of the scene if nothing does (the picture
// cannot depend on it).
struct Unbuilt {
    std::string tag, type;
    const Source* src = nullptr;
    int line = 0;
};

// A shapegroup's shapes, in the group's own space, kept aside until instances place them (meshes.cpp).
struct ShapeGroup {
    std::vector<Mesh> meshes;
    std::vector<Sphere> spheres;
};

// The state shared by the builders while one scene is read. Each member function is defined in the
// file of its kind (see above).
class SceneBuilder : public XmlReader {
public:
    explicit SceneBuilder(const SceneLoadOptions& options) : XmlReader(options) {}

    // scene.cpp: reads the scene file and everything it includes.
    Scene run(const std::string& path);
    void process_scene(const Source& src, pugi::xml_node root);
    void include(const Source& src, pugi::xml_node n);
    void medium(const Source& src, pugi::xml_node n);
    // A top-level <bsdf> or <texture> whose type `supported` does not know: kept in `unbuilt` (true),
    // else false (the caller builds it).
    bool defer_unsupported(const Source& src, pugi::xml_node n, bool (*supported)(const std::string& type));
    // Fails if `id` names an unbuilt plugin: `src`:`line` is the <ref> to it.
    void check_not_unbuilt(const Source& src, int line, const std::string& id) const;
    // <ref name="interior|exterior"> inside a shape: fails naming the medium (media are not built yet).
    [[noreturn]] void medium_ref(const Source& src, pugi::xml_node n, const std::string& side) const;

    // sensor.cpp
    void integrator(const Source& src, pugi::xml_node n);
    void sensor(const Source& src, pugi::xml_node n);
    FilmSettings read_film(const Source& src, pugi::xml_node n);
    void read_sampler(const Source& src, pugi::xml_node n);  // only sampleCount matters: Scene::defaults.spp

    // bsdfs.cpp
    void top_level_bsdf(const Source& src, pugi::xml_node n);
    // Parses a <bsdf> element; a BSDF with an id is also stored for later <ref>s.
    Bsdf parse_bsdf(const Source& src, pugi::xml_node n, std::string* id_out = nullptr, int* line_out = nullptr);
    // A <ref id=...> to a BSDF declared earlier.
    NamedBsdf& named_bsdf(const Source& src, pugi::xml_node n);
    uint32_t add_bsdf(const Bsdf& b);

    // textures.cpp
    void top_level_texture(const Source& src, pugi::xml_node n);
    // A <texture> element -> index into scene.textures. `context` names where it stands, for messages.
    int16_t parse_texture(const Source& src, pugi::xml_node n, const std::string& context, bool top_level = false);
    // <ref id=...> to a texture declared earlier.
    int16_t texture_ref(const Source& src, pugi::xml_node n);
    // Texture coordinates' scale and offset, as Mitsuba's Texture2D reads them (uvscale sets both scales).
    void uv_transform(Plugin& p, Texture* t);
    // Adds a texture, or returns the index of an equal one (`key` describes it completely).
    int16_t add_texture(Texture t, const std::string& key);

    // shapes.cpp
    void shape(const Source& src, pugi::xml_node n);

    // meshes.cpp
    void load_obj(const Source& src, int line, const std::string& file, const Transform& to_world, bool face_normals,
                  bool flip_tex, Mesh* mesh);
    void load_binary_mesh(const Source& src, int line, const std::string& type, const std::string& file, uint32_t index,
                          const Transform& to_world, bool face_normals, Mesh* mesh);
    void build_mesh(const Source& src, int line, const std::vector<Vec3>& pos, const std::vector<Vec3>& nrm,
                    const std::vector<uint32_t>& idx, const Transform& to_world, Mesh* mesh, bool flat = true,
                    const std::string& what = "");
    void shape_group(Plugin& p);
    void instance(Plugin& p);

    // emitters.cpp
    void emitter(const Source& src, pugi::xml_node n);
    // The <emitter type="area"> nested in a shape: makes shape `shape_index` (a sphere or a mesh) a light.
    void area_emitter(const Source& src, pugi::xml_node n, LightType type, uint32_t shape_index);

    Scene scene;
    std::map<std::string, NamedBsdf> named_bsdfs;
    std::map<std::string, NamedTexture> named_textures;
    std::map<std::string, int16_t> texture_by_key;   // texture description -> index: equal ones are shared
    std::map<std::string, int16_t> decoded_by_file;  // file|gamma|channel -> a texture holding its texels
    std::set<std::string> hashed_files;              // texture files already in the fingerprint
    std::map<std::string, ShapeGroup> groups;
    bool have_sensor = false, have_integrator = false;
    int default_bsdf = -1;  // Mitsuba's default diffuse BSDF, added once when a shape has none
    int black_bsdf = -1;    // the all-absorbing one Mitsuba gives an emitting shape without a BSDF
    std::map<std::string, Unbuilt> unbuilt;  // id -> a plugin iris cannot build (defer_unsupported)
    std::vector<Unbuilt> unbuilt_anonymous;  // the same without an id: they can never be used
    struct IgnoredMedium {
        const Source* src;
        int line;
        std::string label;
    };
    std::vector<IgnoredMedium> media;  // warned about at the end, once no shape has referred to one
    int include_depth = 0;
    bool in_group = false;  // reading a shapegroup's shapes
};

// Whether the BSDF / texture tables hold a plugin of this type (bsdfs.cpp, textures.cpp).
bool bsdf_type_supported(const std::string& type);
bool texture_type_supported(const std::string& type);

// sunsky.cpp: the daylight emitters "sky", "sun" and "sunsky" (EmitterBuilders; rows in emitters.cpp's
// table). "sunsky" with sunRadiusScale 0 also adds the sun's directional light to b.scene.lights.
void sky_emitter(SceneBuilder& b, Plugin& e, Light* l);
void sun_emitter(SceneBuilder& b, Plugin& e, Light* l);
void sunsky_emitter(SceneBuilder& b, Plugin& e, Light* l);

// "a, b and c": the names of a plugin table, for "unsupported plugin" messages.
std::string name_list(const std::vector<std::string>& names, const char* last_separator);

}  // namespace iris::mitsuba
