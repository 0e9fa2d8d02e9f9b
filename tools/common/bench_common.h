/* What the Embree 3 and Embree 4 comparison tools share: the command line, the OBJ
 * reader, the ray and hit files of docs/RAYS.md, timing and the report.  Only the calls
 * into Embree differ between the two tools, so everything else lives here, once. */
#ifndef ISIR_BENCH_COMMON_H
#define ISIR_BENCH_COMMON_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>

/* One ray record of a ray file: the first 32 bytes of Embree's RTCRay. */
typedef struct {
    float ox, oy, oz, tmin, dx, dy, dz, tmax;
} RayRecord;

/* One hit record of a hit file. */
typedef struct {
    float t;
    uint32_t prim;
    float u, v;
} HitRecord;

_Static_assert(sizeof(RayRecord) == 32, "ray records are 32 bytes (docs/RAYS.md)");
_Static_assert(sizeof(HitRecord) == 16, "hit records are 16 bytes (docs/RAYS.md)");

/* A miss, and an occluded any-hit result, as docs/RAYS.md writes them. */
#define HIT_MISS_PRIM 0xFFFFFFFFu

/* Triangles as Embree takes them: vertices x, y, z (with room for Embree's 16-byte loads
 * past the last one) and three vertex indices per triangle, in isir's numbering. */
typedef struct {
    float *vertices;
    uint32_t vertex_count;
    uint32_t *indices;
    uint32_t triangle_count;
} Mesh;

typedef enum { QUALITY_LOW, QUALITY_MEDIUM, QUALITY_HIGH } Quality;
typedef enum { MODE_SINGLE, MODE_STREAM, MODE_PACKET16 } Mode;

typedef struct {
    const char *mesh_path;
    const char *rays_path;
    const char *hits_path; /* NULL: no hit file */
    int occluded;
    Quality quality;
    Mode mode;
    int repeat;  /* traces timed this many times, builds min(repeat, 3) times */
    int threads; /* 0: one per core */
    int verbose;
} Options;

/* The program's name in messages ("embree3-bench"), set by parse_options. */
extern const char *bench_program;

/* Print "PROGRAM: message" on stderr and exit with status 1. */
void fail(const char *fmt, ...) __attribute__((noreturn, format(printf, 1, 2)));

/* Parse the command line (exits with a usage message on a bad one). */
void parse_options(const char *program, int argc, char **argv, Options *o);

const char *quality_name(Quality q);
const char *mode_name(Mode m);

/* Read an OBJ file's positions and faces; exits with FILE:LINE: problem on a bad one. */
void load_obj(const char *path, Mesh *mesh);

/* Read a ray file, checking its header and that its size is exactly what the header says. */
RayRecord *load_rays(const char *path, uint64_t *count);

/* Write a hit file whole or not at all (a temporary file beside it, then a rename). */
void write_hits(const char *path, const HitRecord *hits, uint64_t count);

/* A monotonic clock, in milliseconds. */
double now_ms(void);

/* The figures of one run, printed as "key: value" lines (what `isir bench` reads). */
typedef struct {
    const char *engine; /* "embree 3.13.5" */
    const char *note;   /* NULL, or a remark on the mode */
    int threads;
    const Options *options;
    uint64_t triangles, rays, hits;
    double obj_load_ms, build_ms, trace_ms;
    long long memory_bytes, memory_peak_bytes; /* Embree's, after and during the last build */
} Report;

/* What Embree holds, as its device memory monitor reports it (rtcSetDeviceMemoryMonitorFunction):
 * bytes allocated minus bytes freed, and the most at any time since the last reset. */
typedef struct {
    _Atomic long long current, peak;
} MemoryMonitor;

/* The monitor callback (user = a MemoryMonitor); allows every allocation. */
bool memory_monitor(void *user, ssize_t bytes, bool post);

/* Before a build: restart the peak from what is held now, and return that. */
long long memory_mark(MemoryMonitor *m);

/* After it: what the build added (*bytes), and the most it held at once (*peak), above `mark`. */
void memory_since(MemoryMonitor *m, long long mark, long long *bytes, long long *peak);

void print_report(const Report *r);

#endif
