// Mesh geometry: mesh files (OBJ, PLY, Mitsuba serialized) and Mitsuba's built-in shapes to
// world-space Meshes (build_mesh), and shapegroups with their instances.
#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "formats/mitsuba/builder.h"
#include "formats/obj.h"
#include "formats/ply.h"
#include "formats/serialized.h"

namespace iris::mitsuba {

// Reads an OBJ file into `mesh` (world space). Mesh errors name the XML line of the filename.
// Texture coordinates as Mitsuba 0.5/0.6's OBJ loader reads them: with flipTexCoords (its default,
// true) v' = 1 - v, since OBJ's v = 0 is the image's bottom row and Mitsuba's texture lookup has
// v = 0 at the top; without it, as written. Used when every face corner has one; otherwise none.
void SceneBuilder::load_obj(const Source& src, int line, const std::string& file, const Transform& to_world,
                            bool face_normals, bool flip_tex, Mesh* mesh) {
    fs::path path = resolve(src, file);
    std::string text;
    if (!read_file(path, &text))
        fail(src, line, "cannot read mesh file " + quote(file) + " (resolved to " + path.string() + ")");
    fingerprint.add(text);
    ObjMesh obj;
    try {
        obj = parse_obj(text, path.string());
    } catch (const ObjError& e) {
        fail(src, line, "in mesh " + quote(file) + ": " + e.what());
    }
    if (obj.face_sizes.empty()) fail(src, line, "mesh " + quote(file) + " has no faces");

    // Normals are usable when every corner has one; Mitsuba computes them otherwise.
    bool use_normals = !face_normals && !obj.normals.empty();
    if (use_normals) {
        size_t missing = 0;
        for (const ObjMesh::Corner& c : obj.corners) missing += c.n < 0;
        if (missing) {
            warn(src, line, "mesh " + quote(file) + ": " + std::to_string(missing) +
                                " face corners have no normal; computing smooth normals for the whole mesh");
            use_normals = false;
        }
    }

    bool use_uvs = !obj.texcoords.empty();
    if (use_uvs) {
        size_t missing = 0;
        for (const ObjMesh::Corner& c : obj.corners) missing += c.t < 0;
        if (missing) {
            warn(src, line, "mesh " + quote(file) + ": " + std::to_string(missing) +
                                " face corners have no texture coordinate; the mesh gets none (a texture reads each triangle's barycentrics, as in Mitsuba)");
            use_uvs = false;
        }
    }

    // One vertex per distinct (position, normal, texture coordinate), as Mitsuba's OBJ loader does.
    struct Key {
        uint32_t v;
        int32_t n, t;
        bool operator==(const Key& o) const { return v == o.v && n == o.n && t == o.t; }
    };
    struct KeyHash {
        size_t operator()(const Key& k) const {
            return size_t((uint64_t(k.v) * 0x9e3779b97f4a7c15ULL) ^ (uint64_t(uint32_t(k.n)) * 0xc2b2ae3d27d4eb4fULL) ^
                          (uint64_t(uint32_t(k.t)) * 0x165667b19e3779f9ULL));
        }
    };
    std::unordered_map<Key, uint32_t, KeyHash> remap;
    remap.reserve(obj.corners.size());
    std::vector<Vec3> pos, nrm;
    std::vector<Vec2> uv;
    std::vector<uint32_t> corner_vertex(obj.corners.size());
    for (size_t i = 0; i < obj.corners.size(); ++i) {
        const ObjMesh::Corner& c = obj.corners[i];
        const Key key{c.v, use_normals ? c.n : -1, use_uvs ? c.t : -1};
        auto [it, inserted] = remap.emplace(key, uint32_t(pos.size()));
        if (inserted) {
            pos.push_back(obj.positions[c.v]);
            if (use_normals) nrm.push_back(obj.normals[size_t(c.n)]);
            if (use_uvs) {
                Vec2 t = obj.texcoords[size_t(c.t)];
                if (flip_tex) t.y = 1.0f - t.y;
                uv.push_back(t);
            }
        }
        corner_vertex[i] = it->second;
    }
    // Polygons become triangle fans (0, i, i+1), as in Mitsuba's OBJ loader.
    std::vector<uint32_t> idx;
    idx.reserve(3 * obj.corners.size());
    for (size_t f = 0, c = 0; f < obj.face_sizes.size(); c += obj.face_sizes[f], ++f)
        for (uint32_t i = 1; i + 1 < obj.face_sizes[f]; ++i) {
            idx.push_back(corner_vertex[c]);
            idx.push_back(corner_vertex[c + i]);
            idx.push_back(corner_vertex[c + i + 1]);
        }
    build_mesh(src, line, pos, nrm, idx, to_world, mesh, face_normals, file);
    mesh->uvs = std::move(uv);
}

// Reads a PLY or Mitsuba serialized mesh into `mesh` (world space). Errors name the XML line of
// the filename and the mesh file. Normals: the file's, unless flat shading is asked for (the
// faceNormals parameter, or serialized's face-normal flag); none in the file = computed smooth
// ones, as Mitsuba does.
void SceneBuilder::load_binary_mesh(const Source& src, int line, const std::string& type, const std::string& file,
                                    uint32_t index, const Transform& to_world, bool face_normals, Mesh* mesh) {
    fs::path path = resolve(src, file);
    std::string bytes;
    if (!read_file(path, &bytes))
        fail(src, line, "cannot read mesh file " + quote(file) + " (resolved to " + path.string() + ")");
    fingerprint.add(bytes);
    if (type == "serialized") fingerprint.add(std::to_string(index));
    TriangleMesh tm;
    try {
        tm = type == "ply" ? parse_ply(bytes, path.string()) : parse_serialized(bytes, index, path.string());
    } catch (const MeshFileError& e) {
        fail(src, line, "in " + type + " mesh " + quote(file) + ": " + e.what());
    }
    bytes = std::string();  // the file's bytes are no longer needed: free them before the world-space copy
    const bool flat = face_normals || tm.face_normals;
    if (flat) tm.normals.clear();
    build_mesh(src, line, tm.positions, tm.normals, tm.indices, to_world, mesh, flat, file);
    mesh->uvs = std::move(tm.uvs);
}

// ---- shapegroups and instances ----------------------------------------------------------------
// A shapegroup's shapes are kept aside (ShapeGroup) until instances place them.
//
// Instances are flattened: each one is a world-space copy of the group's triangles, so memory
// grows with instances x triangles (12 bytes a vertex, 12 a normal, 8 a uv, 12 a triangle). Embree
// instancing (RTC_GEOMETRY_TYPE_INSTANCE) would share the BVH and the vertices, but Scene::intersect,
// the light samplers and photon emission address world-space Mesh arrays by geometry ID; sharing
// would need instance transforms in each of them. Flattening gives exactly the triangles of explicit
// copies (tests/unit/test_mesh_formats.cpp checks this), which is what matters for correctness.
void SceneBuilder::shape_group(Plugin& p) {
    const Source& src = *p.src;
    if (p.id.empty()) fail(src, p.line, "a shapegroup needs an id (instances refer to it)");
    if (in_group) fail(src, p.line, "shapegroups cannot be nested (Mitsuba does not allow it either)");
    const size_t m0 = scene.meshes.size(), s0 = scene.spheres.size();
    in_group = true;
    for (pugi::xml_node c : p.children) {
        const std::string tag = c.name();
        if (tag != "shape") fail(src, src.line_of(c), "<" + tag + "> is not allowed inside a shapegroup (only <shape>s)");
        if (pugi::xml_node e = c.child("emitter"))
            fail(src, src.line_of(e),
                 "an area emitter inside a shapegroup is not supported (nor in Mitsuba); attach it to a shape outside");
        shape(src, c);
    }
    in_group = false;
    finish(p);
    ShapeGroup g;
    g.meshes.assign(std::make_move_iterator(scene.meshes.begin() + ptrdiff_t(m0)),
                    std::make_move_iterator(scene.meshes.end()));
    g.spheres.assign(scene.spheres.begin() + ptrdiff_t(s0), scene.spheres.end());
    scene.meshes.resize(m0);
    scene.spheres.resize(s0);
    if (g.meshes.empty() && g.spheres.empty()) fail(src, p.line, "shapegroup " + quote(p.id) + " has no shapes");
    groups[p.id] = std::move(g);
}

void SceneBuilder::instance(Plugin& p) {
    const Source& src = *p.src;
    if (in_group) fail(src, p.line, "an instance inside a shapegroup is not supported");
    pugi::xml_node ref;
    for (pugi::xml_node c : p.children) {
        if (std::string_view(c.name()) != "ref")
            fail(src, src.line_of(c), std::string("<") + c.name() + "> is not allowed inside an instance (only a <ref> to a shapegroup)");
        if (ref) fail(src, src.line_of(c), "an instance refers to one shapegroup; this is a second <ref>");
        ref = c;
    }
    if (!ref) fail(src, p.line, "an instance needs a <ref id=\"...\"/> to a shapegroup");
    check_attrs(src, ref, {"id", "name"});
    check_no_text(src, ref);
    const std::string id = attr(src, ref, "id");
    auto it = groups.find(id);
    if (it == groups.end()) {
        if (const IdInfo* known = id_info(id))
            fail(src, src.line_of(ref), "<ref id=" + quote(id) + "> refers to a <" + known->tag + ">, not to a shapegroup");
        fail(src, src.line_of(ref), "undefined shapegroup " + quote(id) + " (it must be declared before its instances)");
    }
    const Transform m = get_transform(p, "toWorld").value_or(Transform());
    finish(p);
    const ShapeGroup& g = it->second;
    for (const Mesh& gm : g.meshes) {
        Mesh out;
        out.name = gm.name + " (instance of " + quote(id) + ")";
        // The group's normals (given or computed) are transformed; flat meshes stay flat.
        build_mesh(src, p.line, gm.positions, gm.normals, gm.indices, m, &out);
        out.uvs = gm.uvs;
        out.bsdf = gm.bsdf;
        out.flip_normals = gm.flip_normals;
        scene.meshes.push_back(std::move(out));
    }
    for (Sphere s : g.spheres) {
        Vec3 ax = m.vector(Vec3(1, 0, 0)), ay = m.vector(Vec3(0, 1, 0)), az = m.vector(Vec3(0, 0, 1));
        float lx = length(ax), ly = length(ay), lz = length(az);
        float tol = 1e-4f * std::max(lx, std::max(ly, lz));
        if (std::abs(lx - ly) > tol || std::abs(lx - lz) > tol || std::abs(dot(ax, ay)) > tol * lx ||
            std::abs(dot(ax, az)) > tol * lx || std::abs(dot(ay, az)) > tol * lx)
            fail(src, p.line, "an instance of a shapegroup with a sphere must scale uniformly (no shear)");
        s.center = m.point(s.center);
        s.radius *= lx;
        // The instance's rotation composes with the sphere's own frame (its uv parameterization).
        const Vec3 fx = m.vector(s.axis_x), fy = m.vector(s.axis_y), fz = m.vector(s.axis_z);
        s.axis_x = fx / length(fx);
        s.axis_y = fy / length(fy);
        s.axis_z = fz / length(fz);
        if (!is_finite(s.center) || !(s.radius > 0) || !std::isfinite(s.radius))
            fail(src, p.line, "an instanced sphere's centre or radius is not finite after toWorld");
        scene.spheres.push_back(s);
    }
}

// Transforms object-space geometry to world space and fills `mesh`: drops zero-area triangles
// (with a warning giving their number), transforms normals with the inverse transpose, and,
// when the mesh has none and flat shading was not asked for, computes angle-weighted vertex
// normals (Thuermer & Wuethrich 1998), as Mitsuba does for OBJs without normals.
void SceneBuilder::build_mesh(const Source& src, int line, const std::vector<Vec3>& pos, const std::vector<Vec3>& nrm,
                              const std::vector<uint32_t>& idx, const Transform& to_world, Mesh* mesh, bool flat,
                              const std::string& what) {
    const std::string label = what.empty() ? "the " + mesh->name : "mesh " + quote(what);
    mesh->positions.resize(pos.size());
    for (size_t i = 0; i < pos.size(); ++i) {
        mesh->positions[i] = to_world.point(pos[i]);
        if (!is_finite(mesh->positions[i])) fail(src, line, label + ": a vertex is not finite after toWorld");
    }
    // A mirroring transform reverses the winding; restore it so that the geometric normal (from
    // the winding) stays on the side the transformed shading normals point to.
    const bool mirror = to_world.determinant3x3() < 0;
    size_t degenerate = 0;
    mesh->indices.clear();
    mesh->indices.reserve(idx.size());
    for (size_t t = 0; t + 2 < idx.size(); t += 3) {
        uint32_t a = idx[t], b = idx[t + 1], c = idx[t + 2];
        if (mirror) std::swap(b, c);
        const Vec3 &p0 = mesh->positions[a], &p1 = mesh->positions[b], &p2 = mesh->positions[c];
        // Area test in double: float cross products of long thin triangles can round to zero.
        double e1[3] = {double(p1.x) - p0.x, double(p1.y) - p0.y, double(p1.z) - p0.z};
        double e2[3] = {double(p2.x) - p0.x, double(p2.y) - p0.y, double(p2.z) - p0.z};
        double cx = e1[1] * e2[2] - e1[2] * e2[1], cy = e1[2] * e2[0] - e1[0] * e2[2],
               cz = e1[0] * e2[1] - e1[1] * e2[0];
        if (cx == 0 && cy == 0 && cz == 0) {
            ++degenerate;
            continue;
        }
        mesh->indices.insert(mesh->indices.end(), {a, b, c});
    }
    if (degenerate)
        warn(src, line, label + ": skipped " + std::to_string(degenerate) + " degenerate (zero-area) triangle" +
                            (degenerate > 1 ? "s" : ""));
    if (mesh->indices.empty()) fail(src, line, label + " has no triangles with non-zero area");

    mesh->normals.clear();
    if (!nrm.empty()) {
        const Transform nt = to_world.inverse().transpose();
        mesh->normals.resize(nrm.size());
        for (size_t i = 0; i < nrm.size(); ++i) {
            Vec3 v = nt.vector(nrm[i]);
            float l = length(v);
            // A zero normal stays zero: the renderer then falls back on the geometric normal.
            mesh->normals[i] = l > 0 && std::isfinite(l) ? v / l : Vec3(0.0f);
        }
    } else if (!flat) {
        std::vector<Vec3> acc(mesh->positions.size(), Vec3(0.0f));
        for (size_t t = 0; t < mesh->indices.size(); t += 3) {
            const uint32_t* f = &mesh->indices[t];
            Vec3 p[3] = {mesh->positions[f[0]], mesh->positions[f[1]], mesh->positions[f[2]]};
            Vec3 fn = cross(p[1] - p[0], p[2] - p[0]);
            float fl = length(fn);
            if (!(fl > 0)) continue;
            fn = fn / fl;
            for (int k = 0; k < 3; ++k) {
                Vec3 e1 = p[(k + 1) % 3] - p[k], e2 = p[(k + 2) % 3] - p[k];
                float l1 = length(e1), l2 = length(e2);
                if (!(l1 > 0 && l2 > 0)) continue;
                float angle = safe_acos(dot(e1, e2) / (l1 * l2));  // interior angle at corner k
                acc[f[k]] += fn * angle;
            }
        }
        mesh->normals.resize(acc.size());
        for (size_t i = 0; i < acc.size(); ++i) {
            float l = length(acc[i]);
            mesh->normals[i] = l > 0 ? acc[i] / l : Vec3(0.0f);
        }
    }
}


}  // namespace iris::mitsuba
