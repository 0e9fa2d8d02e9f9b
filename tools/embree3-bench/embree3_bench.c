/* embree3-bench: trace a ray file (docs/RAYS.md) against the triangles of an OBJ file with
 * Embree 3, as `isir bench` asks, and print the figures as "key: value" lines.
 * See tools/README.md; the command line, OBJ reader and files are in ../common. */
#include <embree3/rtcore.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../common/bench_common.h"

static void on_error(void *user, enum RTCError code, const char *message) {
    (void)user;
    fail("Embree error %d: %s", (int)code, message ? message : "(no message)");
}

static enum RTCBuildQuality rtc_quality(Quality q) {
    return q == QUALITY_LOW ? RTC_BUILD_QUALITY_LOW : q == QUALITY_MEDIUM ? RTC_BUILD_QUALITY_MEDIUM : RTC_BUILD_QUALITY_HIGH;
}

/* A new scene holding the mesh, built (committed). */
static RTCScene build(RTCDevice device, const Mesh *m, Quality quality) {
    RTCScene scene = rtcNewScene(device);
    rtcSetSceneBuildQuality(scene, rtc_quality(quality));
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetGeometryBuildQuality(g, rtc_quality(quality));
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, m->vertices, 0, 3 * sizeof(float), m->vertex_count);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, m->indices, 0, 3 * sizeof(uint32_t), m->triangle_count);
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(scene);
    return scene;
}

static struct RTCRay to_rtc(const RayRecord *r) {
    return (struct RTCRay){.org_x = r->ox, .org_y = r->oy, .org_z = r->oz, .tnear = r->tmin,
                           .dir_x = r->dx, .dir_y = r->dy, .dir_z = r->dz, .time = 0, .tfar = r->tmax,
                           .mask = 0xFFFFFFFFu, .id = 0, .flags = 0};
}

static HitRecord closest(const struct RTCRayHit *rh) {
    if (rh->hit.geomID == RTC_INVALID_GEOMETRY_ID) return (HitRecord){INFINITY, HIT_MISS_PRIM, 0, 0};
    return (HitRecord){rh->ray.tfar, rh->hit.primID, rh->hit.u, rh->hit.v};
}

/* One timed pass over all rays in the chosen mode. */
static void trace(RTCScene scene, const Options *o, const RayRecord *rays, uint64_t n, HitRecord *hits) {
    const int64_t count = (int64_t)n;
    if (o->occluded) {
#pragma omp parallel for schedule(dynamic, 256)
        for (int64_t i = 0; i < count; i++) {
            struct RTCIntersectContext ctx;
            rtcInitIntersectContext(&ctx);
            struct RTCRay ray = to_rtc(&rays[i]);
            rtcOccluded1(scene, &ctx, &ray);
            hits[i] = ray.tfar == -INFINITY ? (HitRecord){0, HIT_MISS_PRIM, 0, 0} : (HitRecord){INFINITY, HIT_MISS_PRIM, 0, 0};
        }
    } else if (o->mode == MODE_SINGLE) {
#pragma omp parallel for schedule(dynamic, 256)
        for (int64_t i = 0; i < count; i++) {
            struct RTCIntersectContext ctx;
            rtcInitIntersectContext(&ctx);
            struct RTCRayHit rh = {.ray = to_rtc(&rays[i])};
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(scene, &ctx, &rh);
            hits[i] = closest(&rh);
        }
    } else if (o->mode == MODE_STREAM) {
        /* Blocks of 256 consecutive (coherent: neighbouring pixels) rays through Embree 3's
         * stream API, which regroups them into packets itself. */
        const int64_t blocks = (count + 255) / 256;
#pragma omp parallel for schedule(dynamic, 1)
        for (int64_t b = 0; b < blocks; b++) {
            struct RTCIntersectContext ctx;
            rtcInitIntersectContext(&ctx);
            ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
            struct RTCRayHit rh[256];
            const int64_t first = b * 256, m = count - first < 256 ? count - first : 256;
            for (int64_t k = 0; k < m; k++) {
                rh[k].ray = to_rtc(&rays[first + k]);
                rh[k].hit.geomID = RTC_INVALID_GEOMETRY_ID;
            }
            rtcIntersect1M(scene, &ctx, rh, (unsigned)m, sizeof rh[0]);
            for (int64_t k = 0; k < m; k++) hits[first + k] = closest(&rh[k]);
        }
    } else {
        /* Packets of 16 consecutive rays (the last one partly valid). */
        const int64_t blocks = (count + 15) / 16;
#pragma omp parallel for schedule(dynamic, 16)
        for (int64_t b = 0; b < blocks; b++) {
            struct RTCIntersectContext ctx;
            rtcInitIntersectContext(&ctx);
            struct RTCRayHit16 p;
            _Alignas(64) int valid[16]; /* Embree reads it with 64-byte aligned loads */
            for (int k = 0; k < 16; k++) {
                const int64_t i = b * 16 + k;
                valid[k] = i < count ? -1 : 0;
                const RayRecord *r = &rays[i < count ? i : b * 16];
                p.ray.org_x[k] = r->ox, p.ray.org_y[k] = r->oy, p.ray.org_z[k] = r->oz, p.ray.tnear[k] = r->tmin;
                p.ray.dir_x[k] = r->dx, p.ray.dir_y[k] = r->dy, p.ray.dir_z[k] = r->dz, p.ray.tfar[k] = r->tmax;
                p.ray.time[k] = 0, p.ray.mask[k] = 0xFFFFFFFFu, p.ray.id[k] = 0, p.ray.flags[k] = 0;
                p.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
            }
            rtcIntersect16(valid, scene, &ctx, &p);
            for (int k = 0; k < 16 && b * 16 + k < count; k++)
                hits[b * 16 + k] = p.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID
                                       ? (HitRecord){INFINITY, HIT_MISS_PRIM, 0, 0}
                                       : (HitRecord){p.ray.tfar[k], p.hit.primID[k], p.hit.u[k], p.hit.v[k]};
        }
    }
}

int main(int argc, char **argv) {
    Options o;
    parse_options("embree3-bench", argc, argv, &o);
    if (o.threads > 0) omp_set_num_threads(o.threads);
    const int threads = omp_get_max_threads();

    double t0 = now_ms();
    Mesh mesh;
    load_obj(o.mesh_path, &mesh);
    const double load_ms = now_ms() - t0;
    uint64_t n;
    RayRecord *rays = load_rays(o.rays_path, &n);
    HitRecord *hits = malloc(n ? n * sizeof *hits : 1);
    if (!hits) fail("out of memory for %llu hits", (unsigned long long)n);

    char config[64];
    snprintf(config, sizeof config, "threads=%d,verbose=%d", threads, o.verbose ? 1 : 0);
    RTCDevice device = rtcNewDevice(config);
    if (!device) fail("rtcNewDevice(\"%s\") failed: error %d", config, (int)rtcGetDeviceError(NULL));
    rtcSetDeviceErrorFunction(device, on_error, NULL);
    static MemoryMonitor memory;
    rtcSetDeviceMemoryMonitorFunction(device, memory_monitor, &memory);
    const long version = (long)rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_VERSION);

    /* Builds: the best of min(repeat, 3), each from scratch (as isir's are timed). */
    RTCScene scene = NULL;
    double build_ms = INFINITY;
    long long memory_bytes = 0, memory_peak_bytes = 0;
    for (int r = 0; r < (o.repeat < 3 ? o.repeat : 3); r++) {
        if (scene) rtcReleaseScene(scene);
        const long long before = memory_mark(&memory);
        const double b0 = now_ms();
        scene = build(device, &mesh, o.quality);
        const double b = now_ms() - b0;
        if (b < build_ms) build_ms = b;
        /* What the built scene holds (the mesh's arrays are shared, not Embree's). */
        memory_since(&memory, before, &memory_bytes, &memory_peak_bytes);
    }

    /* Traces: the best of repeat. */
    double trace_ms = INFINITY;
    for (int r = 0; r < o.repeat; r++) {
        const double s0 = now_ms();
        trace(scene, &o, rays, n, hits);
        const double s = now_ms() - s0;
        if (s < trace_ms) trace_ms = s;
    }

    uint64_t hit_count = 0;
    for (uint64_t i = 0; i < n; i++) hit_count += hits[i].t < INFINITY;
    char engine[64];
    snprintf(engine, sizeof engine, "embree %ld.%ld.%ld", version / 10000, version / 100 % 100, version % 100);
    Report report = {.engine = engine,
                     .threads = threads,
                     .options = &o,
                     .triangles = mesh.triangle_count,
                     .rays = n,
                     .hits = hit_count,
                     .obj_load_ms = load_ms,
                     .build_ms = build_ms,
                     .trace_ms = trace_ms,
                     .memory_bytes = memory_bytes,
                     .memory_peak_bytes = memory_peak_bytes};
    if (o.hits_path) write_hits(o.hits_path, hits, n);
    print_report(&report);

    rtcReleaseScene(scene);
    rtcReleaseDevice(device);
    free(hits);
    free(rays);
    free(mesh.vertices);
    free(mesh.indices);
    return 0;
}
