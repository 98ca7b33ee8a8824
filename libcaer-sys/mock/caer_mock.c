/*
 * A stand-in for libcaer, implementing the functions faithd calls, for tests:
 * one "DAVIS240" that serves a scripted stream of polarity packets (a vertical edge
 * sweeping right, ON events, 1 ms of device time per container), then vanishes (the
 * shutdown callback fires, DataGet returns NULL), refuses a number of opens, and
 * returns. Containers are paced in real time: each is handed out when the device
 * clock, running at a settable rate, has passed its newest event, plus a settable
 * random USB latency. caerDavisInfoGet reports a settable DVS size.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* libcaer 3.x's struct caer_davis_info (devices/davis.h), field for field; the two
   enums are int-sized as C enums are. */
struct caer_davis_info {
    int16_t deviceID;
    char deviceSerialNumber[8 + 1];
    uint8_t deviceUSBBusNumber;
    uint8_t deviceUSBDeviceAddress;
    char *deviceString;
    int16_t firmwareVersion;
    int16_t logicVersion;
    int16_t chipID;
    bool deviceIsMaster;
    bool muxHasStatistics;
    int16_t dvsSizeX;
    int16_t dvsSizeY;
    bool dvsHasPixelFilter;
    bool dvsHasBackgroundActivityFilter;
    bool dvsHasROIFilter;
    bool dvsHasSkipFilter;
    bool dvsHasPolarityFilter;
    bool dvsHasStatistics;
    int16_t apsSizeX;
    int16_t apsSizeY;
    enum { MONO = 0 } apsColorFilter;
    bool apsHasGlobalShutter;
    enum { IMU_NONE = 0 } imuType;
    bool extInputHasGenerator;
};
#if UINTPTR_MAX == 0xFFFFFFFFFFFFFFFFu
_Static_assert(sizeof(struct caer_davis_info) == 64, "libcaer 3 layout");
#endif

struct caer_device_handle {
    int32_t served;
    void (*shutdown)(void *);
    void *shutdown_ptr;
    bool running;
};

struct caer_event_packet_container {
    int32_t packets;
    uint8_t *packet;
};

static int32_t script_before_disconnect = 1000000;
static int32_t script_failed_opens = 0;
static int32_t failed_opens_left = 0;
static int32_t open_attempts = 0;
static bool vanished = false;
static int64_t stream_time_us = 0;
static int64_t config_values[16][64];
static bool config_set[16][64];
static int16_t sensor_width_px = 240, sensor_height_px = 180;
/* Device clock: rate against CLOCK_MONOTONIC, latency range, and the session's
   anchor (host time at which the device read session_device0_us). */
static double clock_rate = 1.0;
static int32_t latency_min_us = 0, latency_max_us = 0;
static int64_t session_host0_us = 0, session_device0_us = 0;
static uint64_t latency_rng = 1;

void caer_mock_script(int32_t containers_before_disconnect, int32_t failed_opens_after) {
    script_before_disconnect = containers_before_disconnect;
    script_failed_opens = failed_opens_after;
    failed_opens_left = 0;
    open_attempts = 0;
    vanished = false;
    stream_time_us = 0;
    memset(config_set, 0, sizeof(config_set));
    sensor_width_px = 240;
    sensor_height_px = 180;
    clock_rate = 1.0;
    latency_min_us = latency_max_us = 0;
    latency_rng = 1;
}

/*
 * A daemon under test loads this library in its own process, out of reach of the
 * script functions: the same script is read from the environment when the library
 * is loaded. CAER_MOCK_SENSOR=WxH, CAER_MOCK_DISCONNECT_AFTER=containers,
 * CAER_MOCK_FAILED_OPENS=opens refused after the disconnect.
 */
__attribute__((constructor)) static void caer_mock_from_env(void) {
    const char *sensor = getenv("CAER_MOCK_SENSOR");
    const char *after = getenv("CAER_MOCK_DISCONNECT_AFTER");
    const char *failed = getenv("CAER_MOCK_FAILED_OPENS");
    int w = 0, h = 0;
    if (sensor && sscanf(sensor, "%dx%d", &w, &h) == 2 && w > 0 && h > 0 && w < 32768 && h < 32768) {
        sensor_width_px = (int16_t) w;
        sensor_height_px = (int16_t) h;
    }
    if (after) script_before_disconnect = (int32_t) atoi(after);
    if (failed) script_failed_opens = (int32_t) atoi(failed);
}

void caer_mock_sensor(int16_t width_px, int16_t height_px) {
    sensor_width_px = width_px;
    sensor_height_px = height_px;
}

void caer_mock_clock(double rate, int32_t min_us, int32_t max_us) {
    clock_rate = rate > 0.0 ? rate : 1.0;
    latency_min_us = min_us < 0 ? 0 : min_us;
    latency_max_us = max_us < latency_min_us ? latency_min_us : max_us;
}

int64_t caer_mock_now_us(void) {
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    return (int64_t) now.tv_sec * 1000000 + now.tv_nsec / 1000;
}

int64_t caer_mock_true_host_us(int64_t device_us) {
    return session_host0_us + (int64_t) ((double) (device_us - session_device0_us) / clock_rate);
}

/* xorshift64: a reproducible latency sequence without libc's global rand state. */
static int32_t next_latency_us(void) {
    latency_rng ^= latency_rng << 13;
    latency_rng ^= latency_rng >> 7;
    latency_rng ^= latency_rng << 17;
    int32_t span = latency_max_us - latency_min_us + 1;
    return latency_min_us + (int32_t) (latency_rng % (uint64_t) span);
}

/* Sleeps until CLOCK_MONOTONIC reaches at_us (a time already past returns at once). */
static void sleep_until_us(int64_t at_us) {
    if (at_us <= 0) return;
    struct timespec t = { .tv_sec = at_us / 1000000, .tv_nsec = (at_us % 1000000) * 1000 };
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &t, NULL) == EINTR) {
    }
}

int32_t caer_mock_open_attempts(void) { return open_attempts; }

int64_t caer_mock_config_value(int8_t mod, uint8_t param) {
    int m = mod + 8;
    if (m < 0 || m >= 16 || param >= 64 || !config_set[m][param]) return -1;
    return config_values[m][param];
}

struct caer_device_handle *caerDeviceOpen(uint16_t id, uint16_t type, uint8_t bus, uint8_t addr,
                                          const char *serial) {
    (void) id; (void) bus; (void) addr; (void) serial;
    open_attempts++;
    if (type != 4) return NULL;
    if (vanished) {
        if (failed_opens_left > 0) { failed_opens_left--; return NULL; }
        vanished = false;
    }
    struct caer_device_handle *h = calloc(1, sizeof *h);
    return h;
}

bool caerDeviceClose(struct caer_device_handle **h) {
    if (h == NULL || *h == NULL) return false;
    free(*h);
    *h = NULL;
    return true;
}

bool caerDeviceSendDefaultConfig(struct caer_device_handle *h) { return h != NULL; }

struct caer_davis_info caerDavisInfoGet(struct caer_device_handle *h) {
    struct caer_davis_info info;
    memset(&info, 0, sizeof info);
    if (h == NULL) return info; /* libcaer: all zeros on failure */
    info.deviceID = 1;
    memcpy(info.deviceSerialNumber, "00000001", 9);
    info.chipID = sensor_width_px == 346 ? 5 /* DAVIS346B */ : 2 /* DAVIS240C */;
    info.deviceIsMaster = true;
    info.dvsSizeX = sensor_width_px;
    info.dvsSizeY = sensor_height_px;
    info.apsSizeX = sensor_width_px;
    info.apsSizeY = sensor_height_px;
    return info;
}

bool caerDeviceConfigSet(struct caer_device_handle *h, int8_t mod, uint8_t param, uint32_t value) {
    int m = mod + 8;
    if (h == NULL || m < 0 || m >= 16 || param >= 64) return false;
    config_values[m][param] = value;
    config_set[m][param] = true;
    return true;
}

bool caerDeviceDataStart(struct caer_device_handle *h, void (*inc)(void *), void (*dec)(void *),
                         void *ptr, void (*shutdown)(void *), void *shutdown_ptr) {
    (void) inc; (void) dec; (void) ptr;
    if (h == NULL || vanished) return false;
    h->shutdown = shutdown;
    h->shutdown_ptr = shutdown_ptr;
    h->running = true;
    session_host0_us = caer_mock_now_us();
    session_device0_us = stream_time_us;
    return true;
}

bool caerDeviceDataStop(struct caer_device_handle *h) {
    if (h == NULL) return false;
    h->running = false;
    return true;
}

static void put_i32(uint8_t *p, int32_t v) { memcpy(p, &v, 4); }
static void put_i16(uint8_t *p, int16_t v) { memcpy(p, &v, 2); }

struct caer_event_packet_container *caerDeviceDataGet(struct caer_device_handle *h) {
    if (h == NULL || !h->running || vanished) return NULL;
    if (h->served >= script_before_disconnect) {
        vanished = true;
        failed_opens_left = script_failed_opens;
        h->running = false;
        if (h->shutdown) h->shutdown(h->shutdown_ptr);
        return NULL;
    }
    /* One container per call: 1 ms of a vertical edge at column (served % width),
       one ON event per row, plus one invalid event that must be skipped. */
    const int32_t rows = 180, n = rows + 1, size = 8;
    /* Handed out once the device clock has passed the newest valid event, plus USB
       latency. */
    int64_t newest_us = stream_time_us + rows - 1;
    sleep_until_us(caer_mock_true_host_us(newest_us) + next_latency_us());
    uint8_t *packet = calloc(1, 28 + (size_t) n * size);
    put_i16(packet + 0, 1);      /* eventType: polarity */
    put_i16(packet + 2, 1);      /* eventSource */
    put_i32(packet + 4, size);   /* eventSize */
    put_i32(packet + 8, 4);      /* eventTSOffset */
    put_i32(packet + 12, 0);     /* eventTSOverflow */
    put_i32(packet + 16, n);     /* eventCapacity */
    put_i32(packet + 20, n);     /* eventNumber */
    put_i32(packet + 24, rows);  /* eventValid */
    int32_t x = h->served % (sensor_width_px > 0 ? sensor_width_px : 240);
    for (int32_t k = 0; k < n; k++) {
        uint8_t *e = packet + 28 + (size_t) k * size;
        bool valid = k < rows;
        uint32_t data = ((uint32_t) x << 17) | ((uint32_t) (k % rows) << 2) | 2u | (valid ? 1u : 0u);
        put_i32(e, (int32_t) data);
        put_i32(e + 4, (int32_t) (stream_time_us + k));
    }
    /* The real eventNumber field sits at offset 20 and eventValid at 24 in libcaer's
       header; faithd reads eventNumber at 20. */
    stream_time_us += 1000;
    h->served++;
    struct caer_event_packet_container *c = calloc(1, sizeof *c);
    c->packets = 1;
    c->packet = packet;
    return c;
}

void caerEventPacketContainerFree(struct caer_event_packet_container *c) {
    if (c == NULL) return;
    free(c->packet);
    free(c);
}

int32_t caerEventPacketContainerGetEventPacketsNumber(struct caer_event_packet_container *c) {
    return c == NULL ? 0 : c->packets;
}

uint8_t *caerEventPacketContainerGetEventPacket(struct caer_event_packet_container *c, int32_t n) {
    if (c == NULL || n != 0) return NULL;
    return c->packet;
}
