// bench-rays: raw Embree throughput on a scene, the yardstick for render's rays/s.
// Casts incoherent closest-hit rays the way a path tracer's bounces look: origins on the surfaces the
// camera sees (found once, untimed), directions uniform on the sphere, one rtcIntersect1 per ray, in
// parallel with TBB. Only the casting is timed: no shading, no sampling, no film.
#include <CLI/CLI.hpp>

#include "tools/common/tool_util.h"
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <thread>

#include "formats/scene_xml.h"
#include "libcommon/accel.h"
#include "libcommon/rng.h"
#include "libcommon/sampling.h"

int main(int argc, char** argv) {
    std::string scene_path;
    long long rays = 4000000;
    int threads = 0, repeats = 3;
    CLI::App app{"bench-rays: raw Embree closest-hit throughput (incoherent rays) on a scene"};
    app.set_version_flag("--version", std::string("iris bench-rays ") + IRIS_VERSION);
    app.add_option("scene", scene_path, "Scene file")->required();
    app.add_option("--rays", rays, "Rays per repetition")->check(CLI::PositiveNumber);
    app.add_option("--repeats", repeats, "Repetitions; the median is reported")->check(CLI::PositiveNumber);
    app.add_option("-t,--threads", threads, "Worker threads (default: all cores)");
    if (int rc = iris::parse_command_line(app, argc, argv, "bench-rays"); rc >= 0) return rc;
    try {
        iris::SceneLoadOptions lo;
        std::vector<std::string> warnings;
        lo.warnings = &warnings;
        iris::Scene scene = iris::load_scene(scene_path, lo);
        if (threads <= 0) threads = int(std::max(1u, std::thread::hardware_concurrency()));
        tbb::global_control gc(tbb::global_control::max_allowed_parallelism, size_t(threads));
        // Origins: first hits of camera rays through random film positions.
        iris::Camera cam = scene.camera;
        const int w = scene.film.width, h = scene.film.height;
        std::vector<iris::Vec3> origins;
        iris::Rng rng(1, 2);
        for (int i = 0; i < 1 << 16; ++i) {
            iris::Ray r;
            r.o = cam.origin;
            r.d = iris::camera_direction(cam, rng.next_float() * w, rng.next_float() * h, w, h);
            iris::SurfaceHit hit;
            if (scene.intersect(r, &hit)) origins.push_back(iris::offset_ray_origin(hit.p, hit.ng, hit.ns));
        }
        if (origins.empty()) throw std::runtime_error(scene_path + ": the camera sees no surface");
        const iris::Accel& accel = *scene.accel;
        std::vector<double> rates;
        unsigned long long hits_total = 0;
        for (int rep = 0; rep < repeats; ++rep) {
            const long long chunk = 4096;
            const long long chunks = (rays + chunk - 1) / chunk;
            std::vector<unsigned> hits(chunks, 0);
            auto t0 = std::chrono::steady_clock::now();
            tbb::parallel_for(0LL, chunks, [&](long long c) {
                iris::Rng r = iris::Rng::for_index(rep, iris::Stream::Test, uint64_t(c));
                unsigned local = 0;
                long long end = std::min(rays, (c + 1) * chunk);
                for (long long i = c * chunk; i < end; ++i) {
                    iris::Ray ray;
                    ray.o = origins[r.next_u32() % origins.size()];
                    ray.d = iris::sample_uniform_sphere({r.next_float(), r.next_float()});
                    float t, u, v;
                    uint32_t g, p;
                    local += accel.intersect(ray, &t, &g, &p, &u, &v);
                }
                hits[c] = local;
            });
            double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            rates.push_back(double(rays) / s);
            for (unsigned x : hits) hits_total += x;
        }
        std::sort(rates.begin(), rates.end());
        std::printf("bench-rays: %s: %.3f Mrays/s (median of %d x %lld rays, %d threads, %.1f %% hits)\n",
                    scene_path.c_str(), rates[rates.size() / 2] * 1e-6, repeats, rays, threads,
                    100.0 * double(hits_total) / double(rays * repeats));
    } catch (const std::exception& e) {
        std::fprintf(stderr, "bench-rays: error: %s\n", e.what());
        return 1;
    }
    return 0;
}
