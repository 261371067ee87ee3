/*
 * A frontseat driver in C, against include/frontseat_driver.h only: a "loopback" frontseat that
 * lives inside the driver. It accepts every desired course, dead-reckons the vehicle from it,
 * and reports a NodeStatus on every loop(), so the interface reaches COMMAND without any
 * simulator. It encodes and decodes the few protobuf fields it needs by hand (no library).
 *
 * Build: cc -shared -fPIC -I include c_example/example_driver.c -o libexample_driver.so -lm
 * Test modes (compile-time):
 *   -DFSD_EXAMPLE_CRASH_ON_COMMAND=5   segfault on the 5th command (crash isolation test)
 *   -DFSD_EXAMPLE_ABI_VERSION=99       claim another ABI version (mismatch test)
 *   -DFSD_EXAMPLE_OMIT_LOOP            do not export frontseat_driver_loop (missing symbol test)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "frontseat_driver.h"

#define FSD_PI 3.14159265358979323846

#ifndef FSD_EXAMPLE_ABI_VERSION
#define FSD_EXAMPLE_ABI_VERSION FRONTSEAT_DRIVER_ABI_VERSION
#endif

struct fsd_driver {
    fsd_host host; /* copied: the host's table */
    double lat, lon, heading, speed, depth;
    double last_loop_s;
    int have_loop;
    unsigned commands;
};

/* ---- protobuf, just enough ---------------------------------------------------------------- */

typedef struct {
    uint8_t buf[512];
    size_t len;
    int overflow;
} pb_out;

static void pb_byte(pb_out *o, uint8_t b) {
    if (o->len < sizeof o->buf)
        o->buf[o->len++] = b;
    else
        o->overflow = 1;
}
static void pb_varint(pb_out *o, uint64_t v) {
    while (v >= 0x80) {
        pb_byte(o, (uint8_t)(v | 0x80));
        v >>= 7;
    }
    pb_byte(o, (uint8_t)v);
}
static void pb_tag(pb_out *o, uint32_t field, uint32_t wire) { pb_varint(o, ((uint64_t)field << 3) | wire); }
static void pb_double(pb_out *o, uint32_t field, double d) {
    uint64_t bits;
    memcpy(&bits, &d, sizeof bits);
    pb_tag(o, field, 1);
    for (int i = 0; i < 8; i++) pb_byte(o, (uint8_t)(bits >> (8 * i)));
}
static void pb_bytes(pb_out *o, uint32_t field, const void *p, size_t n) {
    pb_tag(o, field, 2);
    pb_varint(o, n);
    for (size_t i = 0; i < n; i++) pb_byte(o, ((const uint8_t *)p)[i]);
}
static void pb_message(pb_out *o, uint32_t field, const pb_out *sub) {
    o->overflow |= sub->overflow;
    pb_bytes(o, field, sub->buf, sub->len);
}

typedef struct {
    const uint8_t *p, *end;
} pb_in;

static int pb_read_varint(pb_in *in, uint64_t *v) {
    *v = 0;
    for (int shift = 0; shift < 64 && in->p < in->end; shift += 7) {
        uint8_t b = *in->p++;
        *v |= (uint64_t)(b & 0x7f) << shift;
        if (!(b & 0x80)) return 1;
    }
    return 0;
}
/* Reads one field: its number, wire type, and (varint) value or (fixed64) bits or (LEN) slice. */
static int pb_next(pb_in *in, uint32_t *field, uint32_t *wire, uint64_t *value, pb_in *slice) {
    uint64_t key;
    if (in->p >= in->end || !pb_read_varint(in, &key)) return 0;
    *field = (uint32_t)(key >> 3);
    *wire = (uint32_t)(key & 7);
    switch (*wire) {
    case 0: return pb_read_varint(in, value);
    case 1:
        if (in->end - in->p < 8) return 0;
        *value = 0;
        for (int i = 0; i < 8; i++) *value |= (uint64_t)in->p[i] << (8 * i);
        in->p += 8;
        return 1;
    case 2:
        if (!pb_read_varint(in, value) || (uint64_t)(in->end - in->p) < *value) return 0;
        slice->p = in->p;
        slice->end = in->p + *value;
        in->p += *value;
        return 1;
    case 5:
        if (in->end - in->p < 4) return 0;
        in->p += 4;
        return 1;
    default: return 0;
    }
}
static double bits_double(uint64_t bits) {
    double d;
    memcpy(&d, &bits, sizeof d);
    return d;
}

/* ---- helpers ------------------------------------------------------------------------------- */

static void logf_(struct fsd_driver *d, int level, const char *fmt, double a, double b, double c) {
    char line[256];
    int n = snprintf(line, sizeof line, fmt, a, b, c);
    if (n > 0 && d->host.log) d->host.log(d->host.ctx, level, line, (size_t)n < sizeof line ? (size_t)n : sizeof line - 1);
}

static void emit_node_status(struct fsd_driver *d, double now_s) {
    pb_out fix = {0}, pose = {0}, speed = {0}, ns = {0}, data = {0};
    pb_double(&fix, 1, d->lat);
    pb_double(&fix, 2, d->lon);
    pb_double(&fix, 3, d->depth);
    pb_double(&pose, 3, d->heading);
    pb_double(&speed, 1, d->speed);
    pb_double(&ns, 1, now_s); /* NodeStatus.time: the interface fills wall time when it wants */
    pb_message(&ns, 10, &fix);
    pb_message(&ns, 20, &pose);
    pb_message(&ns, 30, &speed);
    pb_message(&data, 1, &ns); /* InterfaceData.node_status */
    if (!data.overflow) d->host.data_from_frontseat(d->host.ctx, data.buf, data.len);
}

/* ---- the ABI ------------------------------------------------------------------------------- */

uint32_t frontseat_driver_abi_version(void) { return FSD_EXAMPLE_ABI_VERSION; }

fsd_driver *frontseat_driver_load(const fsd_host *host, const uint8_t *config, size_t config_len,
                                  char *error, size_t error_cap) {
    size_t i = 0;
    while (i < config_len && (config[i] == ' ' || config[i] == '\n' || config[i] == '\t')) i++;
    if (i == config_len || config[i] != '{') {
        snprintf(error, error_cap, "config must be a JSON object");
        return NULL;
    }
    if (!host || host->abi_version != FRONTSEAT_DRIVER_ABI_VERSION || !host->data_from_frontseat ||
        !host->command_response || !host->raw_to_frontseat) {
        snprintf(error, error_cap, "host table missing or of another ABI version");
        return NULL;
    }
    struct fsd_driver *d = calloc(1, sizeof *d);
    if (!d) {
        snprintf(error, error_cap, "out of memory");
        return NULL;
    }
    d->host = *host;
    d->lat = 42.358456;
    d->lon = -71.087589;
    logf_(d, FSD_LOG_INFO, "C example driver loaded at %.6f, %.6f%.0f", d->lat, d->lon, 0);
    if (d->host.state_changed) d->host.state_changed(d->host.ctx, FSD_FRONTSEAT_ACCEPTING_COMMANDS, 0);
    return d;
}

int32_t frontseat_driver_send_command(fsd_driver *d, const uint8_t *msg, size_t len) {
    pb_in in = {msg, msg + len}, course = {0, 0}, slice;
    uint32_t field, wire;
    uint64_t v;
    int response_requested = 0, have_course = 0;
    int64_t request_id = -1;
    while (in.p < in.end) {
        if (!pb_next(&in, &field, &wire, &v, &slice)) return FSD_ERR_BAD_MESSAGE;
        if (field == 1 && wire == 2) { course = slice; have_course = 1; }
        if (field == 10 && wire == 0) response_requested = v != 0;
        if (field == 11 && wire == 0) request_id = (int64_t)(int32_t)v;
    }
    d->commands++;
#ifdef FSD_EXAMPLE_CRASH_ON_COMMAND
    if (d->commands == FSD_EXAMPLE_CRASH_ON_COMMAND) {
        volatile int *nowhere = NULL;
        *nowhere = 42; /* SIGSEGV, on purpose */
    }
#endif
    if (have_course) {
        while (course.p < course.end) {
            if (!pb_next(&course, &field, &wire, &v, &slice)) return FSD_ERR_BAD_MESSAGE;
            if (wire != 1) continue;
            if (field == 2) d->heading = bits_double(v);
            if (field == 3) d->speed = bits_double(v);
            if (field == 4) d->depth = bits_double(v);
        }
        char line[128];
        int n = snprintf(line, sizeof line, "CMD,HEADING:%g,SPEED:%g,DEPTH:%g", d->heading, d->speed, d->depth);
        pb_out raw = {0};
        pb_bytes(&raw, 1, line, n > 0 ? (size_t)n : 0); /* Raw.raw */
        pb_tag(&raw, 2, 0);
        pb_varint(&raw, 1); /* Raw.type = RAW_ASCII */
        d->host.raw_to_frontseat(d->host.ctx, raw.buf, raw.len);
    }
    if (response_requested) {
        pb_out r = {0};
        pb_tag(&r, 10, 0);
        pb_varint(&r, have_course ? 1 : 0); /* request_successful */
        if (request_id >= 0) {
            pb_tag(&r, 11, 0);
            pb_varint(&r, (uint64_t)request_id);
        }
        d->host.command_response(d->host.ctx, r.buf, r.len);
    }
    return FSD_OK;
}

int32_t frontseat_driver_send_data(fsd_driver *d, const uint8_t *msg, size_t len) {
    (void)d; (void)msg; (void)len;
    return FSD_OK; /* nothing to forward in a loopback frontseat */
}

int32_t frontseat_driver_send_raw(fsd_driver *d, const uint8_t *msg, size_t len) {
    logf_(d, FSD_LOG_DEBUG, "raw of %.0f bytes ignored%.0f%.0f", (double)len, 0, 0);
    (void)msg;
    return FSD_OK;
}

#ifndef FSD_EXAMPLE_OMIT_LOOP
int32_t frontseat_driver_loop(fsd_driver *d, uint64_t now_us) {
    double now = (double)now_us / 1e6;
    if (d->have_loop) {
        double dt = now - d->last_loop_s, rad = d->heading * FSD_PI / 180.0;
        d->lat += d->speed * cos(rad) * dt / 111320.0;
        d->lon += d->speed * sin(rad) * dt / (111320.0 * cos(d->lat * FSD_PI / 180.0));
    }
    d->last_loop_s = now;
    d->have_loop = 1;
    emit_node_status(d, now);
    return FSD_OK;
}
#endif

int32_t frontseat_driver_frontseat_state(const fsd_driver *d) {
    (void)d;
    return FSD_FRONTSEAT_ACCEPTING_COMMANDS;
}

int32_t frontseat_driver_frontseat_providing_data(const fsd_driver *d) { return d->have_loop; }

void frontseat_driver_unload(fsd_driver *d) { free(d); }
