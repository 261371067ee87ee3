/*
 * frontseat_driver.h — the stable C ABI of frontseat driver plugins, version 1.
 *
 * A driver plugin is a shared library (.so) that exports the nine `frontseat_driver_*` functions
 * below. The interface loads it from FRONTSEAT_DRIVER_LIBRARY (as Goby3 does) or from
 * `driver.library` in its config, by default inside a separate `frontseat driver-host` process,
 * so that a crash in the driver never takes the interface down.
 *
 * Messages cross the ABI as protobuf-encoded byte buffers of Goby3's frontseat messages
 * (package goby.middleware.frontseat.protobuf, see interface_yaml/proto/goby/middleware/frontseat/
 * frontseat.proto): CommandRequest, CommandResponse, InterfaceData and Raw.
 *
 * Threading:
 *  - the host calls the driver's functions one at a time, never concurrently (not necessarily
 *    always from the same thread);
 *  - the driver may call the host's callbacks from any thread, concurrently, at any time from the
 *    start of frontseat_driver_load until frontseat_driver_unload returns; never after.
 *  - buffers passed in either direction are only valid during the call: copy what you keep.
 *
 * Compatibility: any change to this file that is not binary compatible bumps
 * FRONTSEAT_DRIVER_ABI_VERSION; the host refuses a library whose frontseat_driver_abi_version()
 * differs from its own (error "ABI version mismatch").
 */
#ifndef FRONTSEAT_DRIVER_H
#define FRONTSEAT_DRIVER_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define FRONTSEAT_DRIVER_ABI_VERSION 1u

/* Return codes of the operations. */
#define FSD_OK 0
/* The message could not be decoded or is not supported: logged and counted; the driver goes on. */
#define FSD_ERR_BAD_MESSAGE (-1)
/* The driver cannot go on: the host treats it as a driver failure (FS_ERROR, restart with backoff). */
#define FSD_ERR_FATAL (-2)

/* goby.middleware.frontseat.protobuf.FrontSeatState */
#define FSD_FRONTSEAT_NOT_CONNECTED 0
#define FSD_FRONTSEAT_IDLE 1
#define FSD_FRONTSEAT_ACCEPTING_COMMANDS 2
#define FSD_FRONTSEAT_IN_CONTROL 3

/* Log levels of fsd_host.log. */
#define FSD_LOG_ERROR 1
#define FSD_LOG_WARN 2
#define FSD_LOG_INFO 3
#define FSD_LOG_DEBUG 4

/* The driver's own state; opaque to the host. */
typedef struct fsd_driver fsd_driver;

/*
 * What the host gives the driver at load: the four Goby3 signals, a state-change notification and
 * a log sink. Every callback receives `ctx` as its first argument. The struct and the callbacks
 * stay valid until frontseat_driver_unload returns; the driver may keep the pointer.
 */
typedef struct fsd_host {
    /* FRONTSEAT_DRIVER_ABI_VERSION of the host. */
    uint32_t abi_version;
    /* sizeof(fsd_host) as the host compiled it. */
    uint32_t struct_size;
    void *ctx;
    /* signal_command_response: an encoded CommandResponse. */
    void (*command_response)(void *ctx, const uint8_t *msg, size_t len);
    /* signal_data_from_frontseat: an encoded InterfaceData (NodeStatus, CTD, ...). */
    void (*data_from_frontseat)(void *ctx, const uint8_t *msg, size_t len);
    /* signal_raw_from_frontseat: an encoded Raw, what the frontseat sent. */
    void (*raw_from_frontseat)(void *ctx, const uint8_t *msg, size_t len);
    /* signal_raw_to_frontseat: an encoded Raw, what the driver sent to the frontseat. */
    void (*raw_to_frontseat)(void *ctx, const uint8_t *msg, size_t len);
    /* The answers of frontseat_state / frontseat_providing_data changed. Optional to call: the
     * host also asks after every operation; calling it makes a change visible at once. */
    void (*state_changed)(void *ctx, int32_t frontseat_state, int32_t providing_data);
    /* A log line (UTF-8, not NUL-terminated) at one of the FSD_LOG_* levels. */
    void (*log)(void *ctx, int32_t level, const char *msg, size_t len);
} fsd_host;

/* Must return FRONTSEAT_DRIVER_ABI_VERSION; called before anything else. */
uint32_t frontseat_driver_abi_version(void);

/*
 * Goby3's driver constructor. `config` is the interface's configuration as UTF-8 JSON (the
 * `[interface]` TOML section, every field present; the driver reads what it needs, e.g.
 * driver.basic_simulator). Returns the driver, or NULL when the configuration is rejected, after
 * writing a NUL-terminated reason of at most error_cap bytes (including the NUL) to `error`.
 */
fsd_driver *frontseat_driver_load(const fsd_host *host, const uint8_t *config, size_t config_len,
                                  char *error, size_t error_cap);

/* send_command_to_frontseat: an encoded CommandRequest. */
int32_t frontseat_driver_send_command(fsd_driver *driver, const uint8_t *msg, size_t len);
/* send_data_to_frontseat: an encoded InterfaceData. */
int32_t frontseat_driver_send_data(fsd_driver *driver, const uint8_t *msg, size_t len);
/* send_raw_to_frontseat: an encoded Raw. */
int32_t frontseat_driver_send_raw(fsd_driver *driver, const uint8_t *msg, size_t len);
/* Goby3's loop(): called at 10 Hz of simulated time; now_us = simulated µs since the start. */
int32_t frontseat_driver_loop(fsd_driver *driver, uint64_t now_us);
/* frontseat_state(): one of FSD_FRONTSEAT_*. */
int32_t frontseat_driver_frontseat_state(const fsd_driver *driver);
/* frontseat_providing_data(): 1 or 0. */
int32_t frontseat_driver_frontseat_providing_data(const fsd_driver *driver);
/* Stop: close connections, join threads, free the driver. No callbacks after it returns. */
void frontseat_driver_unload(fsd_driver *driver);

#ifdef __cplusplus
}
#endif

#endif /* FRONTSEAT_DRIVER_H */
