/* The command line, OBJ reader, ray and hit files, timing and report shared by
 * embree3-bench and embree4-bench (see bench_common.h and tools/README.md). */
#define _GNU_SOURCE
#include "bench_common.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#if !defined(__BYTE_ORDER__) || __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "ray and hit files are little-endian and are read and written as they lie in memory"
#endif

const char *bench_program = "embree-bench";

void fail(const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "%s: ", bench_program);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    exit(1);
}

static void usage(FILE *to) {
    fprintf(to,
            "usage: %s MESH.obj RAYS [--hits OUT] [--occluded] [--quality low|medium|high]\n"
            "       [--mode single|stream|packet16] [--repeat K] [--threads N] [--verbose]\n"
            "Traces a ray file (docs/RAYS.md) against the triangles of an OBJ file and prints\n"
            "key: value lines (build_ms, mrays_per_s, ...); see tools/README.md.\n",
            bench_program);
}

static void usage_error(const char *fmt, const char *arg) {
    fprintf(stderr, "%s: ", bench_program);
    fprintf(stderr, fmt, arg);
    fputc('\n', stderr);
    usage(stderr);
    exit(2);
}

/* A whole decimal integer in [lo, hi], or a usage error naming the option. */
static int parse_int(const char *option, const char *s, long lo, long hi) {
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi) {
        char msg[160];
        snprintf(msg, sizeof msg, "%s wants a whole number from %ld to %ld, not '%%s'", option, lo, hi);
        usage_error(msg, s);
    }
    return (int)v;
}

void parse_options(const char *program, int argc, char **argv, Options *o) {
    bench_program = program;
    *o = (Options){.quality = QUALITY_MEDIUM, .mode = MODE_SINGLE, .repeat = 5};
    int positional = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        /* The option's value, or a usage error when it is missing. */
        const char *value = i + 1 < argc ? argv[i + 1] : NULL;
        int takes_value = !strcmp(a, "--hits") || !strcmp(a, "--quality") || !strcmp(a, "--mode") ||
                          !strcmp(a, "--repeat") || !strcmp(a, "--threads");
        if (takes_value && !value) usage_error("%s needs a value", a);
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            usage(stdout);
            exit(0);
        } else if (!strcmp(a, "--hits")) {
            o->hits_path = value;
        } else if (!strcmp(a, "--occluded")) {
            o->occluded = 1;
        } else if (!strcmp(a, "--verbose")) {
            o->verbose = 1;
        } else if (!strcmp(a, "--quality")) {
            if (!strcmp(value, "low")) o->quality = QUALITY_LOW;
            else if (!strcmp(value, "medium")) o->quality = QUALITY_MEDIUM;
            else if (!strcmp(value, "high")) o->quality = QUALITY_HIGH;
            else usage_error("--quality is low, medium or high, not '%s'", value);
        } else if (!strcmp(a, "--mode")) {
            if (!strcmp(value, "single")) o->mode = MODE_SINGLE;
            else if (!strcmp(value, "stream")) o->mode = MODE_STREAM;
            else if (!strcmp(value, "packet16")) o->mode = MODE_PACKET16;
            else usage_error("--mode is single, stream or packet16, not '%s'", value);
        } else if (!strcmp(a, "--repeat")) {
            o->repeat = parse_int("--repeat", value, 1, 1000);
        } else if (!strcmp(a, "--threads")) {
            o->threads = parse_int("--threads", value, 1, 4096);
        } else if (a[0] == '-' && a[1]) {
            usage_error("unknown option '%s'", a);
        } else if (positional == 0) {
            o->mesh_path = a, positional++;
        } else if (positional == 1) {
            o->rays_path = a, positional++;
        } else {
            usage_error("one mesh and one ray file, then options: what is '%s'?", a);
        }
        if (takes_value) i++;
    }
    if (positional < 2) usage_error("%s", positional == 0 ? "the mesh (an OBJ file) and the ray file are missing" : "the ray file is missing");
    /* Any-hit queries are single rays, as `isir bench` asks for them: no second code path to trust. */
    if (o->occluded && o->mode != MODE_SINGLE) usage_error("%s", "--occluded traces single rays: use it with --mode single");
}

const char *quality_name(Quality q) {
    return q == QUALITY_LOW ? "low" : q == QUALITY_MEDIUM ? "medium" : "high";
}

const char *mode_name(Mode m) {
    return m == MODE_SINGLE ? "single" : m == MODE_STREAM ? "stream" : "packet16";
}

double now_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

/* ---- Growing arrays, bounded by what the file holds ---- */

static void *grow(void *p, size_t *cap, size_t need, size_t elem) {
    if (need <= *cap) return p;
    size_t n = *cap ? *cap : 1024;
    while (n < need) {
        if (n > SIZE_MAX / 2 / elem) fail("out of memory");
        n *= 2;
    }
    void *q = realloc(p, n * elem);
    if (!q) fail("out of memory (%zu bytes)", n * elem);
    *cap = n;
    return q;
}

/* Open a regular file for reading. Opened without blocking and checked before any read: a
 * FIFO would block in open() itself, a device would never end. */
static FILE *open_regular(const char *path, off_t *size) {
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) fail("%s: %s", path, strerror(errno));
    struct stat st;
    if (fstat(fd, &st) != 0) fail("%s: %s", path, strerror(errno));
    if (!S_ISREG(st.st_mode)) fail("%s: not a regular file", path);
    if (fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) & ~O_NONBLOCK) != 0) fail("%s: %s", path, strerror(errno));
    FILE *f = fdopen(fd, "rb");
    if (!f) fail("%s: %s", path, strerror(errno));
    *size = st.st_size;
    return f;
}

/* ---- OBJ ---- */

/* A short, printable excerpt of a token for messages (a line may be megabytes long). */
static const char *excerpt(const char *s) {
    static char buf[48];
    size_t n = 0;
    for (; s[n] && n + 4 < sizeof buf; n++) buf[n] = (s[n] >= 32 && s[n] < 127) ? s[n] : '?';
    if (s[n]) memcpy(buf + n, "...", 4);
    else buf[n] = 0;
    return buf;
}

static int parse_float(const char *s, float *out) {
    char *end;
    *out = strtof(s, &end); /* inf and nan are read, as isir reads them (they are never hit) */
    return end != s && *end == 0;
}

/* One face corner "v", "v/vt", "v//vn" or "v/vt/vn": the position index, 0-based, resolved
 * against the vertices read so far when negative (relative), as isir's reader (tobj) does.
 * Positive indices are checked against the whole file at its end. */
static int64_t parse_corner(char *tok, uint32_t vertices_so_far, const char *path, unsigned long line) {
    int slashes = 0;
    for (const char *c = tok; *c; c++) slashes += *c == '/';
    if (slashes > 2) fail("%s:%lu: face corner '%s' has more than three parts", path, line, excerpt(tok));
    char *parts[3] = {tok, NULL, NULL};
    int n = 1;
    for (char *slash; (slash = strchr(parts[n - 1], '/'));) {
        *slash = 0;
        parts[n++] = slash + 1;
    }
    int64_t v = 0;
    for (int k = 0; k < n; k++) {
        if (k > 0 && !*parts[k]) continue; /* v//vn */
        char *end;
        errno = 0;
        long long x = strtoll(parts[k], &end, 10);
        if (errno || end == parts[k] || *end || x == 0)
            fail("%s:%lu: face corner part '%s' is not a vertex index (a non-zero whole number)", path, line, excerpt(parts[k]));
        if (k == 0) v = x;
    }
    if (v < 0) {
        if (-v > (int64_t)vertices_so_far)
            fail("%s:%lu: relative vertex index %lld reaches before the first vertex (%u so far)", path, line, (long long)v,
                 vertices_so_far);
        return (int64_t)vertices_so_far + v;
    }
    if (v > (int64_t)UINT32_MAX - 1) fail("%s:%lu: vertex index %lld is out of range", path, line, (long long)v);
    return v - 1;
}

void load_obj(const char *path, Mesh *mesh) {
    off_t size;
    FILE *f = open_regular(path, &size);
    unsigned char magic[2] = {0, 0};
    if (fread(magic, 1, 2, f) == 2 && magic[0] == 0x1f && magic[1] == 0x8b)
        fail("%s: a gzip file: decompress it first (gunzip -k); `isir bench` passes a plain OBJ", path);
    rewind(f);

    float *v = NULL;
    size_t v_cap = 0, v_len = 0; /* floats */
    uint32_t *t = NULL;
    size_t t_cap = 0, t_len = 0; /* indices */
    uint32_t *face = NULL;
    size_t face_cap = 0;
    uint32_t max_index = 0;
    unsigned long max_index_line = 0;
    char *line = NULL;
    size_t line_cap = 0;
    ssize_t len;
    unsigned long line_no = 0;
    while ((len = getline(&line, &line_cap, f)) != -1) {
        line_no++;
        char *s = line;
        if (line_no == 1 && len >= 3 && !memcmp(s, "\xEF\xBB\xBF", 3)) s += 3; /* a UTF-8 byte order mark */
        if (memchr(line, 0, (size_t)len)) fail("%s:%lu: a NUL byte: not a text OBJ file", path, line_no);
        char *save;
        char *key = strtok_r(s, " \t\r\n\v\f", &save);
        if (!key) continue;
        if (!strcmp(key, "v")) {
            float xyzw[4] = {0, 0, 0, 1};
            int n = 0;
            for (char *w; n < 7 && (w = strtok_r(NULL, " \t\r\n\v\f", &save)); n++) {
                float x;
                if (!parse_float(w, &x)) fail("%s:%lu: '%s' is not a number", path, line_no, excerpt(w));
                if (n < 4) xyzw[n] = x;
            }
            /* x y z, x y z w (homogeneous: divided by w, as isir's reader does) or x y z r g b */
            if (n != 3 && n != 4 && n != 6) fail("%s:%lu: a vertex has 3, 4 or 6 numbers, not %d", path, line_no, n);
            if (n == 4 && xyzw[3] == 0) fail("%s:%lu: a vertex with w = 0", path, line_no);
            if (v_len / 3 >= UINT32_MAX - 1) fail("%s:%lu: more than %u vertices", path, line_no, UINT32_MAX - 2);
            v = grow(v, &v_cap, v_len + 3, sizeof *v);
            for (int k = 0; k < 3; k++) v[v_len++] = n == 4 ? xyzw[k] / xyzw[3] : xyzw[k];
        } else if (!strcmp(key, "f")) {
            size_t n = 0;
            for (char *w; (w = strtok_r(NULL, " \t\r\n\v\f", &save));) {
                int64_t i = parse_corner(w, (uint32_t)(v_len / 3), path, line_no);
                face = grow(face, &face_cap, n + 1, sizeof *face);
                face[n++] = (uint32_t)i;
                if ((uint32_t)i >= max_index) max_index = (uint32_t)i, max_index_line = line_no;
            }
            /* Faces of one or two corners have no triangle; polygons are fans (v0, vi, vi+1)
             * in file order: the numbering of docs/RAYS.md. */
            for (size_t k = 1; k + 1 < n; k++) {
                if (t_len / 3 >= UINT32_MAX - 1) fail("%s:%lu: more than %u triangles", path, line_no, UINT32_MAX - 2);
                t = grow(t, &t_cap, t_len + 3, sizeof *t);
                t[t_len++] = face[0], t[t_len++] = face[k], t[t_len++] = face[k + 1];
            }
        }
        /* Everything else (normals, texture coordinates, groups, materials, lines) has no
         * triangle and no effect on the numbering. */
    }
    if (ferror(f)) fail("%s: read error: %s", path, strerror(errno));
    fclose(f);
    free(line);
    free(face);
    uint32_t nv = (uint32_t)(v_len / 3);
    if (t_len > 0 && max_index >= nv)
        fail("%s:%lu: vertex index %u is out of range (the file has %u vertices)", path, max_index_line, max_index + 1, nv);
    if (t_len == 0) fail("%s: no triangles", path);
    /* Embree reads vertices with 16-byte loads: readable padding after the last one. */
    v = grow(v, &v_cap, v_len + 4, sizeof *v);
    memset(v + v_len, 0, 4 * sizeof *v);
    *mesh = (Mesh){.vertices = v, .vertex_count = nv, .indices = t, .triangle_count = (uint32_t)(t_len / 3)};
}

/* ---- Ray and hit files (docs/RAYS.md) ---- */

RayRecord *load_rays(const char *path, uint64_t *count) {
    off_t size;
    FILE *f = open_regular(path, &size);
    unsigned char h[24];
    if (fread(h, 1, sizeof h, f) != sizeof h) fail("%s: too short for a ray file header (24 bytes)", path);
    if (memcmp(h, "ISIRRAYS", 8)) fail("%s: not a ray file (magic is not ISIRRAYS)", path);
    uint32_t version;
    memcpy(&version, h + 8, 4);
    if (version != 1) fail("%s: ray file version %u, this tool reads version 1", path, version);
    memcpy(count, h + 16, 8);
    uint64_t body = (uint64_t)size - sizeof h;
    if (body % sizeof(RayRecord) || body / sizeof(RayRecord) != *count)
        fail("%s: the header says %llu rays but the file holds %llu bytes of records (%llu rays and %llu bytes)", path,
             (unsigned long long)*count, (unsigned long long)body, (unsigned long long)(body / sizeof(RayRecord)),
             (unsigned long long)(body % sizeof(RayRecord)));
    /* Bounded by the file's real size; an empty set (a scene seen from outside) is valid. */
    RayRecord *rays = malloc(*count ? *count * sizeof(RayRecord) : 1);
    if (!rays) fail("%s: out of memory for %llu rays", path, (unsigned long long)*count);
    if (fread(rays, sizeof(RayRecord), *count, f) != *count) fail("%s: read error", path);
    fclose(f);
    return rays;
}

void write_hits(const char *path, const HitRecord *hits, uint64_t count) {
    /* The file is replaced by a rename: never a device, a FIFO or a folder in its place. */
    /* Past a file-size limit, a write fails (EFBIG) and is reported instead of killing us. */
    signal(SIGXFSZ, SIG_IGN);
    struct stat st;
    if (stat(path, &st) == 0 && !S_ISREG(st.st_mode)) fail("%s: not a regular file: not replaced by the hit file", path);
    size_t n = strlen(path) + 32;
    char *tmp = malloc(n);
    if (!tmp) fail("out of memory");
    snprintf(tmp, n, "%s.tmp%ld", path, (long)getpid());
    FILE *f = fopen(tmp, "wb");
    if (!f) fail("%s: %s", tmp, strerror(errno));
    unsigned char h[24] = "ISIRHITS";
    uint32_t version = 1, reserved = 0;
    memcpy(h + 8, &version, 4);
    memcpy(h + 12, &reserved, 4);
    memcpy(h + 16, &count, 8);
    int ok = fwrite(h, 1, sizeof h, f) == sizeof h && fwrite(hits, sizeof *hits, count, f) == count && fflush(f) == 0 &&
             fsync(fileno(f)) == 0;
    int err = ok ? 0 : errno;
    if (fclose(f) != 0 && ok) ok = 0, err = errno;
    if (ok && rename(tmp, path) != 0) ok = 0, err = errno;
    if (!ok) {
        unlink(tmp);
        fail("%s: not written: %s", path, strerror(err));
    }
    free(tmp);
}

/* ---- Report ---- */

void print_report(const Report *r) {
    const Options *o = r->options;
    printf("engine: %s\n", r->engine);
    printf("threads: %d\n", r->threads);
    printf("mode: %s%s\n", o->occluded ? "occluded-" : "", mode_name(o->mode));
    if (r->note) printf("note: %s\n", r->note);
    printf("quality: %s\n", quality_name(o->quality));
    printf("triangles: %llu\n", (unsigned long long)r->triangles);
    printf("rays: %llu\n", (unsigned long long)r->rays);
    printf("hits: %llu\n", (unsigned long long)r->hits);
    printf("obj_load_ms: %.1f\n", r->obj_load_ms);
    printf("build_ms: %.3f\n", r->build_ms);
    printf("build_mtris_per_s: %.3f\n", r->triangles / r->build_ms * 1e-3);
    printf("memory_bytes: %lld\n", r->memory_bytes);
    printf("memory_peak_bytes: %lld\n", r->memory_peak_bytes);
    printf("memory_bytes_per_triangle: %.1f\n", r->triangles ? (double)r->memory_bytes / (double)r->triangles : 0.0);
    printf("trace_ms: %.3f\n", r->trace_ms);
    printf("mrays_per_s: %.3f\n", r->rays ? r->rays / r->trace_ms * 1e-3 : 0.0);
    if (fflush(stdout) != 0) fail("writing the report: %s", strerror(errno));
}

bool memory_monitor(void *user, ssize_t bytes, bool post) {
    (void)post;
    MemoryMonitor *m = user;
    const long long now = atomic_fetch_add(&m->current, (long long)bytes) + (long long)bytes;
    long long peak = atomic_load(&m->peak);
    while (now > peak && !atomic_compare_exchange_weak(&m->peak, &peak, now)) {
    }
    return true;
}

long long memory_mark(MemoryMonitor *m) {
    const long long now = atomic_load(&m->current);
    atomic_store(&m->peak, now);
    return now;
}

void memory_since(MemoryMonitor *m, long long mark, long long *bytes, long long *peak) {
    *bytes = atomic_load(&m->current) - mark;
    *peak = atomic_load(&m->peak) - mark;
}
