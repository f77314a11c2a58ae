// <shape> plugins: spheres, Mitsuba's built-in meshes (rectangle, cube, disk) and mesh files (obj,
// ply, serialized; read in meshes.cpp), with the BSDF and the area emitter a shape carries. Each
// plugin is one builder function registered in kShapes; shapegroups and instances are in meshes.cpp.
#include <algorithm>
#include <cmath>

#include "formats/mitsuba/builder.h"

namespace iris::mitsuba {
namespace {

// What a shape builder gets: the element, the index of its BSDF in scene.bsdfs and flipNormals.
// It adds its sphere or mesh to the scene and says which (`light_type`, `index`: for an area
// emitter), and may set `ignore` for parameters it accepts without using them.
struct ShapeArgs {
    SceneBuilder& b;
    Plugin& p;
    uint32_t bsdf;
    bool flip;
    LightType light_type = LightType::AreaMesh;
    uint32_t index = 0;
    IgnoreRule ignore;
};
using ShapeBuilder = void (*)(ShapeArgs& a);
// The geometry of a mesh shape, in world space (`to_world`: the shape's toWorld).
using MeshBuilder = void (*)(ShapeArgs& a, const Transform& to_world, Mesh* mesh);

void sphere(ShapeArgs& a) {
    SceneBuilder& b = a.b;
    Plugin& p = a.p;
    const Source& src = *p.src;
    Sphere s;
    Vec3 center = b.get_point(p, "center").value_or(Vec3(0.0f));
    float radius = b.get_float(p, "radius", 1.0f);
    if (!(radius > 0)) fail(src, p.line, "sphere radius must be positive");
    if (auto m = b.get_transform(p, "toWorld")) {
        // Mitsuba: toWorld * translate(center) * scale(radius); only a similarity keeps it a sphere.
        Vec3 ax = m->vector(Vec3(1, 0, 0)), ay = m->vector(Vec3(0, 1, 0)), az = m->vector(Vec3(0, 0, 1));
        float lx = length(ax), ly = length(ay), lz = length(az);
        float tol = 1e-4f * std::max(lx, std::max(ly, lz));
        if (std::abs(lx - ly) > tol || std::abs(lx - lz) > tol || std::abs(dot(ax, ay)) > tol * lx ||
            std::abs(dot(ax, az)) > tol * lx || std::abs(dot(ay, az)) > tol * lx)
            fail(src, b.find(p, "toWorld")->line, "a sphere's toWorld must scale uniformly (no shear)");
        center = m->point(center);
        radius *= lx;
        s.axis_x = ax / lx;  // the uv parameterization's frame (Scene::intersect)
        s.axis_y = ay / ly;
        s.axis_z = az / lz;
    }
    // As for mesh vertices: a transform can push a valid sphere out of float range.
    if (!is_finite(center) || !(radius > 0) || !std::isfinite(radius))
        fail(src, p.line, "sphere centre or radius is not finite (or zero) after toWorld");
    s.center = center;
    s.radius = radius;
    s.bsdf = a.bsdf;
    s.flip_normals = a.flip;
    b.scene.spheres.push_back(s);
    a.index = uint32_t(b.scene.spheres.size() - 1);
    a.light_type = LightType::AreaSphere;
}

// Every mesh shape: reads toWorld, builds the mesh with `build`, adds it to the scene.
template <MeshBuilder build>
void mesh_shape(ShapeArgs& a) {
    Mesh mesh;
    mesh.name = a.p.id;
    const Transform to_world = a.b.get_transform(a.p, "toWorld").value_or(Transform());
    build(a, to_world, &mesh);
    mesh.bsdf = a.bsdf;
    mesh.flip_normals = a.flip;
    a.b.scene.meshes.push_back(std::move(mesh));
    a.index = uint32_t(a.b.scene.meshes.size() - 1);
}

void obj(ShapeArgs& a, const Transform& to_world, Mesh* mesh) {
    SceneBuilder& b = a.b;
    Plugin& p = a.p;
    Prop* fprop = b.find(p, "filename");
    std::optional<std::string> file = b.get_string(p, "filename");
    if (!file) fail(*p.src, p.line, "shape \"obj\" needs a filename");
    if (mesh->name.empty()) mesh->name = *file;
    const bool face_normals = b.get_bool(p, "faceNormals", false);
    const bool flip_tex = b.get_bool(p, "flipTexCoords", true);
    b.load_obj(*p.src, fprop->line, *file, to_world, face_normals, flip_tex, mesh);
    if (Prop* m = b.find(p, "maxSmoothAngle"))
        fail(*p.src, m->line, "maxSmoothAngle is not supported (give normals in the OBJ or use faceNormals)");
}

// ply and serialized.
void binary_mesh(ShapeArgs& a, const Transform& to_world, Mesh* mesh) {
    SceneBuilder& b = a.b;
    Plugin& p = a.p;
    const std::string& t = p.type;
    Prop* fprop = b.find(p, "filename");
    std::optional<std::string> file = b.get_string(p, "filename");
    if (!file) fail(*p.src, p.line, "shape " + quote(t) + " needs a filename");
    if (mesh->name.empty()) mesh->name = *file;
    const bool face_normals = b.get_bool(p, "faceNormals", false);
    uint32_t shape_index = 0;
    if (t == "serialized") {
        const int si = b.get_int(p, "shapeIndex", 0);
        if (si < 0) fail(*p.src, b.find(p, "shapeIndex")->line, "shapeIndex must not be negative");
        shape_index = uint32_t(si);
    }
    if (Prop* m = b.find(p, "maxSmoothAngle"))
        fail(*p.src, m->line, "maxSmoothAngle is not supported (give normals in the mesh or use faceNormals)");
    b.load_binary_mesh(*p.src, fprop->line, t, *file, shape_index, to_world, face_normals, mesh);
    a.ignore = [](const std::string& name) -> const char* {
        if (name == "srgb") return "it concerns vertex colours, which iris does not use";
        return nullptr;
    };
}

// Mitsuba: [-1,1]^2 in the z = 0 plane, facing +z.
void rectangle(ShapeArgs& a, const Transform& to_world, Mesh* mesh) {
    if (mesh->name.empty()) mesh->name = "rectangle";
    std::vector<Vec3> pos = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
    std::vector<uint32_t> idx = {0, 1, 2, 0, 2, 3};
    a.b.build_mesh(*a.p.src, a.p.line, pos, {}, idx, to_world, mesh);
    mesh->uvs = {Vec2{0, 0}, Vec2{1, 0}, Vec2{1, 1}, Vec2{0, 1}};  // as Mitsuba's rectangle
}

// Mitsuba's cube: [-1,1]^3, flat faces, each face mapped onto [0,1]^2 in uv. Its corners in
// Mitsuba's order (faces -y, +y, +x, +z, -x, -z; triangles (0,1,2), (3,0,2) per face,
// counter-clockwise seen from outside), each face's four corners at uv (0,1), (1,1), (1,0), (0,0),
// so that a texture lands on every face as in Mitsuba.
void cube(ShapeArgs& a, const Transform& to_world, Mesh* mesh) {
    if (mesh->name.empty()) mesh->name = "cube";
    static const signed char kCorners[24][3] = {
        {1, -1, -1}, {1, -1, 1},  {-1, -1, 1}, {-1, -1, -1}, {1, 1, -1},  {-1, 1, -1}, {-1, 1, 1},  {1, 1, 1},
        {1, -1, -1}, {1, 1, -1},  {1, 1, 1},   {1, -1, 1},   {1, -1, 1},  {1, 1, 1},   {-1, 1, 1},  {-1, -1, 1},
        {-1, -1, 1}, {-1, 1, 1},  {-1, 1, -1}, {-1, -1, -1}, {1, 1, -1},  {1, -1, -1}, {-1, -1, -1}, {-1, 1, -1}};
    static const Vec2 kFaceUv[4] = {{0, 1}, {1, 1}, {1, 0}, {0, 0}};
    std::vector<Vec3> pos;
    std::vector<Vec2> uv;
    std::vector<uint32_t> idx;
    for (int i = 0; i < 24; ++i) {
        pos.push_back(Vec3(kCorners[i][0], kCorners[i][1], kCorners[i][2]));
        uv.push_back(kFaceUv[i % 4]);
    }
    for (uint32_t f = 0; f < 6; ++f)
        for (uint32_t k : {0u, 1u, 2u, 3u, 0u, 2u}) idx.push_back(4 * f + k);
    a.b.build_mesh(*a.p.src, a.p.line, pos, {}, idx, to_world, mesh);
    mesh->uvs = std::move(uv);
}

// Mitsuba: the unit disk in the z = 0 plane, facing +z. Tessellated (kDiskSegments triangles) with
// the radius chosen so that the polygon's area is exactly pi, so that an emitting disk sends out
// Mitsuba's power; the rim lies within 1.6e-5 of the circle, relative to the radius.
void disk(ShapeArgs& a, const Transform& to_world, Mesh* mesh) {
    if (mesh->name.empty()) mesh->name = "disk";
    constexpr int kDiskSegments = 512;
    const double step = 2 * double(kPi) / kDiskSegments;
    const double r = std::sqrt(double(kPi) / (0.5 * kDiskSegments * std::sin(step)));
    // uv = Mitsuba's (radius, angle / 2 pi). Linear interpolation over a fan cannot give the
    // angle near the centre from one centre vertex, nor cross the seam at angle 0 = 1: so each
    // segment has its own centre vertex at its mid-angle, and the rim vertex closing the last
    // segment is a copy of the first at v = 1. The angle is then off by at most half a
    // segment (1 / 1024) near the centre and exact on the rim.
    std::vector<Vec3> pos;
    std::vector<Vec2> uv;
    std::vector<uint32_t> idx;
    for (int i = 0; i <= kDiskSegments; ++i) {
        const int k = i % kDiskSegments;  // the same position for i = 0 and i = kDiskSegments
        pos.push_back(Vec3(float(r * std::cos(k * step)), float(r * std::sin(k * step)), 0.0f));
        uv.push_back(Vec2{1.0f, float(i) / kDiskSegments});
    }
    for (int i = 0; i < kDiskSegments; ++i) {
        pos.push_back(Vec3(0.0f));
        uv.push_back(Vec2{0.0f, (float(i) + 0.5f) / kDiskSegments});
        idx.insert(idx.end(), {uint32_t(pos.size() - 1), uint32_t(i), uint32_t(i + 1)});
    }
    a.b.build_mesh(*a.p.src, a.p.line, pos, {}, idx, to_world, mesh);
    mesh->uvs = std::move(uv);
}

// The shape plugins (shapegroup and instance are handled before these, in SceneBuilder::shape).
struct ShapePlugin {
    const char* name;
    ShapeBuilder build;
};
const ShapePlugin kShapes[] = {
    {"obj", mesh_shape<obj>},
    {"ply", mesh_shape<binary_mesh>},
    {"serialized", mesh_shape<binary_mesh>},
    {"sphere", sphere},
    {"rectangle", mesh_shape<rectangle>},
    {"disk", mesh_shape<disk>},
    {"cube", mesh_shape<cube>},
};

// The shape's nested <bsdf> or <ref> (added to scene.bsdfs, or Mitsuba's default diffuse) and its
// nested <emitter> element, if any.
uint32_t shape_children(SceneBuilder& b, const Plugin& p, pugi::xml_node* emitter_node) {
    const Source& src = *p.src;
    std::optional<uint32_t> bsdf;
    for (pugi::xml_node c : p.children) {
        std::string tag = c.name();
        if (tag == "ref") {
            const std::string name = b.opt_attr(src, c, "name").value_or("");
            if (name == "interior" || name == "exterior") b.medium_ref(src, c, name);
        }
        if (tag == "bsdf" || tag == "ref") {
            if (bsdf) fail(src, src.line_of(c), "a shape has one bsdf; this is a second one");
            if (tag == "bsdf") {
                std::string id;
                Bsdf bs = b.parse_bsdf(src, c, &id);
                bsdf = b.add_bsdf(bs);
                if (!id.empty()) {
                    b.named_bsdfs[id].index = int(*bsdf);
                    b.named_bsdfs[id].used = true;
                }
            } else {
                NamedBsdf& nb = b.named_bsdf(src, c);
                if (nb.index < 0) nb.index = int(b.add_bsdf(nb.bsdf));
                bsdf = uint32_t(nb.index);
            }
        } else if (tag == "emitter") {
            if (*emitter_node) fail(src, src.line_of(c), "a shape can carry one emitter; this is a second one");
            *emitter_node = c;
        } else if (tag == "medium" || tag == "subsurface") {
            fail(src, src.line_of(c), "<" + tag + "> on shapes is not supported (no participating media in iris)");
        } else {
            fail(src, src.line_of(c), "<" + tag + "> is not allowed inside a shape");
        }
    }
    if (!bsdf && *emitter_node) {
        // Mitsuba's Shape::configure: an emitter (or sensor, or subsurface integrator; iris reads
        // neither on a shape) without a BSDF gets an all-absorbing one -- diffuse, reflectance 0.
        if (b.black_bsdf < 0) {
            Bsdf black;
            black.diffuse = RGB(0.0f);
            b.black_bsdf = int(b.add_bsdf(black));
        }
        bsdf = uint32_t(b.black_bsdf);
    } else if (!bsdf) {
        // Otherwise diffuse, reflectance 0.5 (a medium transition would get a null BSDF; media are
        // refused). One shared instance.
        if (b.default_bsdf < 0) b.default_bsdf = int(b.add_bsdf(Bsdf()));
        bsdf = uint32_t(b.default_bsdf);
    }
    return *bsdf;
}

}  // namespace

void SceneBuilder::shape(const Source& src, pugi::xml_node n) {
    Plugin p = read_plugin(src, n);
    if (p.type == "shapegroup") return shape_group(p);
    if (p.type == "instance") return instance(p);
    pugi::xml_node emitter_node;
    const uint32_t bsdf = shape_children(*this, p, &emitter_node);
    // A masked emitter: Mitsuba emits its full radiance from every point and lets rays through the mask
    // (its emitter ignores the BSDF), while iris's masked surface is not there for the rays that pass:
    // light sampling and rays that hit the emitter would disagree.
    if (emitter_node && bsdf_is_masked(scene.bsdfs[bsdf]))
        fail(src, src.line_of(emitter_node), "an area emitter on a shape whose bsdf is a mask is not supported");
    const bool flip = get_bool(p, "flipNormals", false);
    const ShapePlugin* plugin = nullptr;
    std::vector<std::string> names;
    for (const ShapePlugin& k : kShapes) {
        names.push_back(k.name);
        if (p.type == k.name) plugin = &k;
    }
    if (!plugin) {
        get_transform(p, "toWorld");  // read before the type is judged, as for every mesh shape
        names.insert(names.end(), {"shapegroup", "instance"});
        fail(src, p.line, "unsupported shape type " + quote(p.type) + " (supported: " + name_list(names, ", ") + ")");
    }
    ShapeArgs args{*this, p, bsdf, flip, LightType::AreaMesh, 0, {}};
    plugin->build(args);
    finish(p, args.ignore);
    if (emitter_node) area_emitter(src, emitter_node, args.light_type, args.index);
}

}  // namespace iris::mitsuba
