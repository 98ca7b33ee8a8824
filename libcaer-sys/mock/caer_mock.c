/*
 * A stand-in for iniVation's libcaer 3.x, for tests: the functions faithd loads, over
 * one scripted "DAVIS240". Written from libcaer 3.3.9's public headers and from what
 * its DAVIS driver is documented (and was measured) to do, not from its code:
 *
 * - include/libcaer/events/packetContainer.h: the container is a packed struct, int64
 *   lowestEventTimestamp, int64 highestEventTimestamp, int32 eventsNumber, int32
 *   eventsValidNumber, int32 eventPacketsNumber (offset 24), then the packet pointers
 *   (offset 28, unaligned on 64-bit targets); it is calloc'ed with every slot NULL,
 *   both timestamps -1, and its statistics are recomputed from the first and last
 *   event of every non-empty packet each time a packet is set. Everything in that
 *   header is static inline: the shared library does not export
 *   caerEventPacketContainerFree, ...GetEventPacketsNumber or ...GetEventPacket, and
 *   neither does this mock (faithd implements the three in libcaer-sys).
 * - include/libcaer/events/common.h, polarity.h, special.h, frame.h, imu6.h: the
 *   28-byte packed packet header (eventType, eventSource, eventSize, eventTSOffset,
 *   eventTSOverflow, eventCapacity, eventNumber, eventValid), packets calloc'ed at
 *   their capacity, and each event type's size and timestamp offset.
 * - A DAVIS container has four slots, indexed by event type: SPECIAL_EVENT (0),
 *   POLARITY_EVENT (1), FRAME_EVENT (2), IMU6_EVENT (3); a slot with nothing is NULL.
 *   A timestamp reset comes alone, in a container of one slot holding a special packet
 *   with one TIMESTAMP_RESET event stamped INT32_MAX; the device's time restarts at 0.
 * - include/libcaer/devices/davis.h: module and parameter addresses. caerDeviceConfigSet
 *   refuses a (module, parameter) the DAVIS240 does not have, read-only ones included.
 * - caerDeviceDataStart turns the DVS, APS, IMU and external-input run flags on;
 *   caerDeviceDataStop turns them off. DataStop on a device whose DataStart never ran
 *   or failed reaches a NULL ring buffer in libcaer (SIGSEGV): this mock aborts there.
 * - caerDeviceDataGet in blocking mode (CAER_HOST_CONFIG_DATAEXCHANGE_BLOCKING, off
 *   by default) waits for a container, retrying after 1 ms sleeps (data_exchange.h,
 *   dataExchangeGet), and gives up with NULL after 1.11-1.22 s without data, as
 *   libcaer 3.3.x was measured to (the give-up here is drawn in that range); in
 *   non-blocking mode it returns NULL at once when nothing is ready; once transfers
 *   stop (the device went away) it returns NULL at once.
 * - When the device goes away, libcaer's USB thread stops the transfers and then
 *   calls the shutdown callback given to DataStart: from that thread, not from DataGet.
 *
 * The stream: a vertical edge sweeping right (ON events, one per row and column, one
 * column per millisecond of device time, as many as the container interval holds:
 * 10 ms unless CAER_HOST_CONFIG_PACKETS_MAX_CONTAINER_INTERVAL is set, plus one
 * invalid event), paced in real time (a container is
 * handed out once the device clock, at a settable rate, has passed its newest event,
 * plus a settable random USB latency), an optional quiet gap (a dark scene), then the
 * device vanishes after a scripted number of containers, refuses some opens and
 * returns; after it went away, the two containers still queued are handed out
 * before DataGet returns NULL. A DVXplorer (caer_mock_device) has its own info call,
 * configuration modules (dvxplorer.h) and no APS. caerDeviceDiscover reports the one
 * camera, or none while it is away, with the error flags an unusable camera sets.
 * Frames and IMU samples are interleaved while the APS and IMU run, and a
 * run flag turned off takes effect only after the containers already in flight.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
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

/* The container as packetContainer.h lays it out (packed). */
struct caer_event_packet_container {
    int64_t lowestEventTimestamp;
    int64_t highestEventTimestamp;
    int32_t eventsNumber;
    int32_t eventsValidNumber;
    int32_t eventPacketsNumber;
    uint8_t *eventPackets[];
} __attribute__((__packed__));
_Static_assert(offsetof(struct caer_event_packet_container, eventPacketsNumber) == 24, "packed");
_Static_assert(offsetof(struct caer_event_packet_container, eventPackets) == 28, "packed");

/* Event types (events/common.h) and their slots in a DAVIS container. */
enum { SPECIAL_EVENT = 0, POLARITY_EVENT = 1, FRAME_EVENT = 2, IMU6_EVENT = 3, DAVIS_SLOTS = 4 };
/* Special event types (events/special.h). */
enum { TIMESTAMP_RESET = 1, EXTERNAL_INPUT_RISING_EDGE = 2 };
#define PACKET_HEADER_BYTES 28
#define POLARITY_EVENT_BYTES 8
#define SPECIAL_EVENT_BYTES 8
#define IMU6_EVENT_BYTES 36
/* A frame event: nine 32-bit fields, then the pixels (frame.h); its timestamp is
   ts_endframe, at offset 8. */
#define FRAME_EVENT_HEADER_BYTES 36
/* Capacities libcaer's DAVIS driver allocates its packets with (more than a container
   usually holds: readers must stop at eventNumber). */
#define POLARITY_CAPACITY 4096
#define SPECIAL_CAPACITY 128
#define IMU6_CAPACITY 64
#define FRAME_CAPACITY 1

/* Module addresses (devices/device.h, usb.h, davis.h). */
enum {
    HOST_USB = -1, HOST_DATAEXCHANGE = -2, HOST_PACKETS = -3, HOST_LOG = -4,
    MOD_MUX = 0, MOD_DVS = 1, MOD_APS = 2, MOD_IMU = 3, MOD_EXTINPUT = 4, MOD_BIAS = 5,
    MOD_SYSINFO = 6, MOD_USB = 9,
};
#define DATAEXCHANGE_BLOCKING 1
#define DVS_RUN 3
#define APS_RUN 4
#define IMU_RUN_ACCELEROMETER 2
#define IMU_RUN_GYROSCOPE 3
#define IMU_RUN_TEMPERATURE 4
#define EXTINPUT_RUN_DETECTOR 0
#define MUX_RUN 0
#define MUX_TIMESTAMP_RUN 1
#define MUX_RUN_CHIP 3
#define USB_RUN 0

/* Containers already in the USB buffers when a run flag goes off: their frames and
   IMU samples still arrive. */
#define IN_FLIGHT_CONTAINERS 4

struct caer_device_handle {
    int32_t served;
    void (*shutdown)(void *);
    void *shutdown_ptr;
    bool started;
    bool reset_sent;
    atomic_bool transfers;
    bool notifier_started;
    pthread_t notifier;
    /* Containers served while the APS / IMU ran, as seen by the data path. */
    int32_t aps_off_from, imu_off_from;
    /* Containers still in the ring buffer after the device went away. */
    int32_t queued_left;
};

static int32_t script_before_disconnect = 1000000;
static int32_t script_failed_opens = 0;
static int32_t failed_opens_left = 0;
static int32_t open_attempts = 0;
static atomic_bool vanished = false;
static int64_t stream_time_us = 0;
static int32_t quiet_after = -1;
static int64_t quiet_us = 0;
/* Modules -8..23: the host's (negative), the DAVIS's and the DVXplorer's (20-23). */
#define CONFIG_MODULES 32
static int64_t config_values[CONFIG_MODULES][256];
static bool config_set[CONFIG_MODULES][256];
/* The caller's own writes (not the library's): -1 never, 0 before DataStart, 1 while
   started. */
static int8_t caller_write[CONFIG_MODULES][256];
static bool blocking = false;
static int16_t sensor_width_px = 240, sensor_height_px = 180;
/* The camera: CAER_DEVICE_DAVIS (4) or CAER_DEVICE_DVXPLORER (8), and what makes it
   unusable (UNUSABLE_*). */
static uint16_t device_type = 4;
static int32_t unusable = 0;
enum { UNUSABLE_PERMISSION = 1, UNUSABLE_VERSION = 2, UNUSABLE_BUSY = 3 };
static int32_t failures = 0;
static int32_t starts = 0, stops = 0, closes = 0;
static int32_t packets_served[DAVIS_SLOTS];
static atomic_int shutdown_calls = 0;
/* Device clock: rate against CLOCK_MONOTONIC, latency range, and the session's
   anchor (host time at which the device read session_device0_us). */
static double clock_rate = 1.0;
static int32_t latency_min_us = 0, latency_max_us = 0;
static int64_t session_host0_us = 0, session_device0_us = 0;
static uint64_t latency_rng = 1;
static const char *call_log_path = NULL;
int64_t caer_mock_now_us(void);

/* One line per device call, appended and closed at once so that a reader sees it
   even when the process is killed right after. */
static void log_call(const char *call) {
    if (call_log_path == NULL) return;
    FILE *f = fopen(call_log_path, "a");
    if (f == NULL) return;
    fprintf(f, "%lld %s\n", (long long) caer_mock_now_us(), call);
    fclose(f);
}

/* What the script can make fail (caer_mock_fail, CAER_MOCK_FAIL). */
enum { FAIL_DEFAULT_CONFIG = 1, FAIL_DATA_START = 2, FAIL_INFO = 4 };

void caer_mock_script(int32_t containers_before_disconnect, int32_t failed_opens_after) {
    script_before_disconnect = containers_before_disconnect;
    script_failed_opens = failed_opens_after;
    failed_opens_left = 0;
    open_attempts = 0;
    atomic_store(&vanished, false);
    stream_time_us = 0;
    quiet_after = -1;
    quiet_us = 0;
    memset(config_set, 0, sizeof(config_set));
    memset(caller_write, -1, sizeof(caller_write));
    blocking = false;
    sensor_width_px = 240;
    sensor_height_px = 180;
    device_type = 4;
    unusable = 0;
    failures = 0;
    starts = stops = closes = 0;
    memset(packets_served, 0, sizeof(packets_served));
    atomic_store(&shutdown_calls, 0);
    clock_rate = 1.0;
    latency_min_us = latency_max_us = 0;
    latency_rng = 1;
}

/*
 * A daemon under test loads this library in its own process, out of reach of the
 * script functions: the same script is read from the environment when the library
 * is loaded. CAER_MOCK_SENSOR=WxH, CAER_MOCK_DISCONNECT_AFTER=containers,
 * CAER_MOCK_FAILED_OPENS=opens refused after the disconnect, CAER_MOCK_FAIL=a sum of
 * 1 (default config refused), 2 (data start fails), 4 (no DVS size),
 * CAER_MOCK_QUIET=after,gap_us (a dark scene, as caer_mock_quiet),
 * CAER_MOCK_DEVICE=dvxplorer (a DVXplorer instead of a DAVIS: caer_mock_device),
 * CAER_MOCK_UNUSABLE=permission|version|busy (caer_mock_unusable), and
 * CAER_MOCK_LOG=a file to which every Open, DataStart, DataStop and Close is appended
 * as it happens (a line each, with CLOCK_MONOTONIC in microseconds), for a test to
 * read what a process it does not share did to the device.
 */
__attribute__((constructor)) static void caer_mock_from_env(void) {
    memset(caller_write, -1, sizeof(caller_write));
    const char *sensor = getenv("CAER_MOCK_SENSOR");
    const char *after = getenv("CAER_MOCK_DISCONNECT_AFTER");
    const char *failed = getenv("CAER_MOCK_FAILED_OPENS");
    const char *fail = getenv("CAER_MOCK_FAIL");
    int w = 0, h = 0;
    if (sensor && sscanf(sensor, "%dx%d", &w, &h) == 2 && w > 0 && h > 0 && w < 32768 && h < 32768) {
        sensor_width_px = (int16_t) w;
        sensor_height_px = (int16_t) h;
    }
    if (after) script_before_disconnect = (int32_t) atoi(after);
    if (failed) script_failed_opens = (int32_t) atoi(failed);
    if (fail) failures = (int32_t) atoi(fail);
    const char *quiet = getenv("CAER_MOCK_QUIET");
    long long gap = 0;
    int q_after = 0;
    if (quiet && sscanf(quiet, "%d,%lld", &q_after, &gap) == 2 && q_after >= 0 && gap >= 0) {
        quiet_after = q_after;
        quiet_us = (int64_t) gap;
    }
    call_log_path = getenv("CAER_MOCK_LOG");
    const char *device = getenv("CAER_MOCK_DEVICE");
    if (device && strcmp(device, "dvxplorer") == 0) device_type = 8;
    const char *why = getenv("CAER_MOCK_UNUSABLE");
    if (why && strcmp(why, "permission") == 0) unusable = UNUSABLE_PERMISSION;
    if (why && strcmp(why, "version") == 0) unusable = UNUSABLE_VERSION;
    if (why && strcmp(why, "busy") == 0) unusable = UNUSABLE_BUSY;
}

/* The camera's family: 4 (DAVIS) or 8 (DVXplorer); `set` restores the DAVIS. */
void caer_mock_device(uint16_t type) { device_type = type; }

/* What makes the camera on USB unusable: 0 nothing, 1 no permission, 2 firmware too
   old, 3 claimed by another program; `set` restores 0. */
void caer_mock_unusable(int32_t why) { unusable = why; }

void caer_mock_sensor(int16_t width_px, int16_t height_px) {
    sensor_width_px = width_px;
    sensor_height_px = height_px;
}

void caer_mock_fail(int32_t what) { failures = what; }

/* After `after_containers` containers, the scene goes dark for `gap_us` of device
   time: no events, so a blocking DataGet times out. */
void caer_mock_quiet(int32_t after_containers, int64_t gap_us) {
    quiet_after = after_containers;
    quiet_us = gap_us;
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

/* xorshift64 of its own for the blocking give-up, apart from the latency's. */
static uint64_t give_up_rng = 0x9E3779B97F4A7C15u;
static uint64_t next_give_up_rng(void) {
    give_up_rng ^= give_up_rng << 13;
    give_up_rng ^= give_up_rng >> 7;
    give_up_rng ^= give_up_rng << 17;
    return give_up_rng;
}

int32_t caer_mock_open_attempts(void) { return open_attempts; }

/* 0: DataStart calls that succeeded, 1: DataStop calls, 2: Close calls, 3: shutdown
   callbacks made. */
int32_t caer_mock_count(int32_t what) {
    switch (what) {
        case 0: return starts;
        case 1: return stops;
        case 2: return closes;
        case 3: return atomic_load(&shutdown_calls);
        default: return -1;
    }
}

/* Packets of an event type handed out in containers since the script was set. */
int32_t caer_mock_packets_served(int32_t event_type) {
    return event_type >= 0 && event_type < DAVIS_SLOTS ? packets_served[event_type] : -1;
}

static bool config_index(int8_t mod, int *m) {
    *m = mod + 8;
    return *m >= 0 && *m < CONFIG_MODULES;
}

int64_t caer_mock_config_value(int8_t mod, uint8_t param) {
    int m;
    if (!config_index(mod, &m) || !config_set[m][param]) return -1;
    return config_values[m][param];
}

/* Whether the caller's last caerDeviceConfigSet of (module, parameter) came after a
   successful DataStart (and before the DataStop that ended it): 1, 0, or -1 when the
   caller never wrote it. */
int32_t caer_mock_config_written_while_started(int8_t mod, uint8_t param) {
    int m;
    if (!config_index(mod, &m)) return -1;
    return caller_write[m][param];
}

/* The device's state of (module, parameter), whoever wrote it. */
static void store_config(int8_t mod, uint8_t param, uint32_t value) {
    int m;
    if (!config_index(mod, &m)) return;
    config_values[m][param] = value;
    config_set[m][param] = true;
}

static bool config_is(int8_t mod, uint8_t param, int64_t value) {
    return caer_mock_config_value(mod, param) == value;
}

/* The (module, parameter) pairs a DAVIS240 takes (davis.h), as this mock's device
   reports them: no pixel, background-activity, ROI, skip or polarity filter, no
   global shutter, no external-input generator. Read-only parameters are refused. */
static bool davis240_takes(int8_t mod, uint8_t p) {
    switch (mod) {
        case HOST_USB: return p <= 1;
        case HOST_DATAEXCHANGE: return p <= 3;
        case HOST_PACKETS: return p <= 1;
        case HOST_LOG: return p == 0;
        case MOD_MUX: return p <= 5;
        case MOD_DVS: return p >= 3 && p <= 5;
        case MOD_APS: return p == 4 || p == 5 || (p >= 8 && p <= 13) || (p >= 100 && p <= 102);
        case MOD_IMU: return (p >= 2 && p <= 7) || p == 9 || p == 10;
        case MOD_EXTINPUT: return p <= 5;
        case MOD_BIAS: return p <= 21 || (p >= 128 && p <= 142);
        case MOD_USB: return p <= 1;
        default: return false;
    }
}

/* The (module, parameter) pairs a DVXplorer takes (dvxplorer.h): MUX, DVS run, the
   IMU's writable ones, external input, USB, and the sensor's modules 20-23. */
static bool dvxplorer_takes(int8_t mod, uint8_t p) {
    switch (mod) {
        case HOST_USB: return p <= 1;
        case HOST_DATAEXCHANGE: return p <= 3;
        case HOST_PACKETS: return p <= 1;
        case HOST_LOG: return p == 0;
        case MOD_MUX: return p <= 5;
        case MOD_DVS: return p == 3;
        case MOD_IMU: return p >= 2 && p <= 10;
        case MOD_EXTINPUT: return p <= 5 || (p >= 11 && p <= 16);
        case MOD_USB: return p <= 1;
        case 20: return p <= 46;
        case 21: return p <= 4;
        case 22: return p <= 5;
        case 23: return p <= 10 || p == 20;
        default: return false;
    }
}

static bool device_takes(int8_t mod, uint8_t p) {
    return device_type == 8 ? dvxplorer_takes(mod, p) : davis240_takes(mod, p);
}

/* caerDeviceDiscover's result (devices/device_discover.h): the type and the two
   error flags, then (at 8) the family's info, whose first fields the DAVIS and
   DVXplorer infos share; 104 bytes an entry on 64-bit targets (the union is as large
   as struct caer_edvs_info). */
#define DISCOVERY_RESULT_BYTES (8 + 96)

/* As usbDeviceFind (usb_utils.c) reports the one camera: none while it is away; an
   open error when libusb_open is refused; a version error (firmware 3 where the
   DAVIS240 needs 4, logic 17 where 18) when it is too old; neither when it is only
   claimed by another program. */
long caerDeviceDiscover(int16_t type, void **out) {
    *out = NULL;
    log_call("Discover");
    if (atomic_load(&vanished) || (type != -1 && (uint16_t) type != device_type)) return 0;
    uint8_t *r = calloc(1, DISCOVERY_RESULT_BYTES);
    if (r == NULL) return -1;
    uint16_t t = device_type;
    memcpy(r, &t, 2);
    r[2] = unusable == UNUSABLE_PERMISSION;
    r[3] = unusable == UNUSABLE_VERSION;
    uint8_t *info = r + 8;
    memcpy(info + 2, "00000001", 9);
    info[11] = 1; /* bus */
    info[12] = 5; /* address */
    int16_t fw = unusable == UNUSABLE_VERSION ? 3 : 4, logic = unusable == UNUSABLE_VERSION ? 17 : 18;
    int16_t chip = unusable == UNUSABLE_PERMISSION ? 0 : (device_type == 8 ? 20 : (sensor_width_px == 346 ? 5 : 2));
    memcpy(info + 24, &fw, 2);
    memcpy(info + 26, &logic, 2);
    memcpy(info + 28, &chip, 2);
    *out = r;
    return 1;
}

struct caer_device_handle *caerDeviceOpen(uint16_t id, uint16_t type, uint8_t bus, uint8_t addr,
                                          const char *serial) {
    (void) id; (void) bus; (void) addr; (void) serial;
    open_attempts++;
    log_call("Open");
    if (type != device_type || unusable != 0) return NULL;
    if (atomic_load(&vanished)) {
        if (failed_opens_left > 0) { failed_opens_left--; return NULL; }
        atomic_store(&vanished, false);
    }
    struct caer_device_handle *h = calloc(1, sizeof *h);
    return h;
}

static void join_notifier(struct caer_device_handle *h) {
    if (h->notifier_started) {
        pthread_join(h->notifier, NULL);
        h->notifier_started = false;
    }
}

bool caerDeviceClose(struct caer_device_handle **h) {
    if (h == NULL || *h == NULL) return false;
    closes++;
    log_call("Close");
    join_notifier(*h);
    free(*h);
    *h = NULL;
    return true;
}

bool caerDeviceSendDefaultConfig(struct caer_device_handle *h) {
    if (h == NULL || (failures & FAIL_DEFAULT_CONFIG)) return false;
    return true;
}

struct caer_davis_info caerDavisInfoGet(struct caer_device_handle *h) {
    struct caer_davis_info info;
    memset(&info, 0, sizeof info);
    if (h == NULL || (failures & FAIL_INFO) || device_type != 4) return info; /* libcaer: zeros */
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

/* libcaer 3's struct caer_dvx_info (devices/dvxplorer.h). */
struct caer_dvx_info {
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
    bool dvsHasStatistics;
    enum { DVX_IMU_NONE = 0 } imuType;
    bool extInputHasGenerator;
};
#if UINTPTR_MAX == 0xFFFFFFFFFFFFFFFFu
_Static_assert(sizeof(struct caer_dvx_info) == 48, "libcaer 3 layout");
#endif

struct caer_dvx_info caerDVXplorerInfoGet(struct caer_device_handle *h) {
    struct caer_dvx_info info;
    memset(&info, 0, sizeof info);
    if (h == NULL || (failures & FAIL_INFO) || device_type != 8) return info;
    info.deviceID = 1;
    memcpy(info.deviceSerialNumber, "00000001", 9);
    info.chipID = sensor_width_px == 320 ? 19 /* Lite */ : 20;
    info.deviceIsMaster = true;
    info.dvsSizeX = sensor_width_px;
    info.dvsSizeY = sensor_height_px;
    return info;
}

bool caerDeviceConfigSet(struct caer_device_handle *h, int8_t mod, uint8_t param, uint32_t value) {
    if (h == NULL || !device_takes(mod, param)) return false;
    if (mod == HOST_DATAEXCHANGE && param == DATAEXCHANGE_BLOCKING) blocking = value != 0;
    store_config(mod, param, value);
    int m;
    if (config_index(mod, &m)) caller_write[m][param] = h->started ? 1 : 0;
    if (h->started) {
        if (mod == MOD_APS && param == APS_RUN && value == 0 && h->aps_off_from < 0)
            h->aps_off_from = h->served + IN_FLIGHT_CONTAINERS;
        if (mod == MOD_IMU && (param >= IMU_RUN_ACCELEROMETER && param <= IMU_RUN_TEMPERATURE)
            && config_is(MOD_IMU, IMU_RUN_ACCELEROMETER, 0) && config_is(MOD_IMU, IMU_RUN_GYROSCOPE, 0)
            && config_is(MOD_IMU, IMU_RUN_TEMPERATURE, 0) && h->imu_off_from < 0)
            h->imu_off_from = h->served + IN_FLIGHT_CONTAINERS;
    }
    return true;
}

/* What libcaer's davisDataStart writes once transfers run (davis.c): every run flag
   on. */
static void run_flags(bool on) {
    store_config(MOD_MUX, MUX_RUN_CHIP, on);
    store_config(MOD_USB, USB_RUN, on);
    store_config(MOD_MUX, MUX_TIMESTAMP_RUN, on);
    store_config(MOD_MUX, MUX_RUN, on);
    store_config(MOD_DVS, DVS_RUN, on);
    if (device_type == 4) store_config(MOD_APS, APS_RUN, on);
    store_config(MOD_IMU, IMU_RUN_ACCELEROMETER, on);
    store_config(MOD_IMU, IMU_RUN_GYROSCOPE, on);
    store_config(MOD_IMU, IMU_RUN_TEMPERATURE, on);
    store_config(MOD_EXTINPUT, EXTINPUT_RUN_DETECTOR, on);
}

bool caerDeviceDataStart(struct caer_device_handle *h, void (*inc)(void *), void (*dec)(void *),
                         void *ptr, void (*shutdown)(void *), void *shutdown_ptr) {
    (void) inc; (void) dec; (void) ptr;
    if (h == NULL || atomic_load(&vanished) || (failures & FAIL_DATA_START)) return false;
    if (h->started) {
        fprintf(stderr, "caer_mock: caerDeviceDataStart on a device already started\n");
        abort();
    }
    h->shutdown = shutdown;
    h->shutdown_ptr = shutdown_ptr;
    h->started = true;
    h->reset_sent = false;
    h->aps_off_from = h->imu_off_from = -1;
    atomic_store(&h->transfers, true);
    run_flags(true);
    starts++;
    log_call("DataStart");
    stream_time_us = 0;
    session_host0_us = caer_mock_now_us();
    session_device0_us = 0;
    return true;
}

bool caerDeviceDataStop(struct caer_device_handle *h) {
    if (h == NULL) return false;
    if (!h->started) {
        /* libcaer: davisDataStop -> davisCommonDataStop -> dataExchangeBufferEmpty on
           a ring buffer DataStart never made: a NULL dereference. */
        fprintf(stderr, "caer_mock: caerDeviceDataStop on a device that was never started "
                        "(libcaer would crash here)\n");
        abort();
    }
    atomic_store(&h->transfers, false);
    join_notifier(h);
    run_flags(false);
    h->started = false;
    stops++;
    log_call("DataStop");
    return true;
}

static void put_i32(uint8_t *p, int32_t v) { memcpy(p, &v, 4); }
static void put_i16(uint8_t *p, int16_t v) { memcpy(p, &v, 2); }
static void put_f32(uint8_t *p, float v) { memcpy(p, &v, 4); }
static int32_t get_i32(const uint8_t *p) { int32_t v; memcpy(&v, p, 4); return v; }

/* A packet as caerEventPacketAllocate makes it: zeroed (every event invalid), the
   header filled in but for eventNumber and eventValid. */
static uint8_t *packet_allocate(int16_t type, int32_t capacity, int32_t event_bytes, int32_t ts_offset,
                                int32_t ts_overflow) {
    uint8_t *p = calloc(1, PACKET_HEADER_BYTES + (size_t) capacity * (size_t) event_bytes);
    if (p == NULL) return NULL;
    put_i16(p + 0, type);
    put_i16(p + 2, 1); /* eventSource: the device ID */
    put_i32(p + 4, event_bytes);
    put_i32(p + 8, ts_offset);
    put_i32(p + 12, ts_overflow);
    put_i32(p + 16, capacity);
    return p;
}

static uint8_t *event_at(uint8_t *p, int32_t k) {
    return p + PACKET_HEADER_BYTES + (size_t) k * (size_t) get_i32(p + 4);
}

/* A 64-bit device time as a packet holds it: overflow in the header, 31 bits per
   event (common.h: TS_OVERFLOW_SHIFT 31). */
static int32_t overflow_of(int64_t t_us) { return (int32_t) (t_us >> 31); }
static int32_t ts31(int64_t t_us) { return (int32_t) (t_us & 0x7FFFFFFF); }

static int64_t event_time(uint8_t *p, int32_t k) {
    int64_t overflow = get_i32(p + 12);
    return (overflow << 31) | (int64_t) get_i32(event_at(p, k) + get_i32(p + 8));
}

/* caerEventPacketContainerAllocate: calloc'ed, every slot NULL, timestamps -1. */
static struct caer_event_packet_container *container_allocate(int32_t slots) {
    struct caer_event_packet_container *c =
        calloc(1, sizeof(struct caer_event_packet_container) + (size_t) slots * sizeof(uint8_t *));
    if (c == NULL) return NULL;
    c->eventPacketsNumber = slots;
    c->lowestEventTimestamp = -1;
    c->highestEventTimestamp = -1;
    return c;
}

/* caerEventPacketContainerSetEventPacket: the slot, then the statistics again from
   the first and last event of every non-empty packet. */
static void container_set(struct caer_event_packet_container *c, int32_t slot, uint8_t *packet) {
    c->eventPackets[slot] = packet;
    int64_t lowest = -1, highest = -1;
    int32_t number = 0, valid = 0;
    for (int32_t s = 0; s < c->eventPacketsNumber; s++) {
        uint8_t *p = c->eventPackets[s];
        if (p == NULL || get_i32(p + 20) == 0) continue;
        int64_t first = event_time(p, 0), last = event_time(p, get_i32(p + 20) - 1);
        if (lowest == -1 || lowest > first) lowest = first;
        if (highest == -1 || highest < last) highest = last;
        number += get_i32(p + 20);
        valid += get_i32(p + 24);
    }
    c->lowestEventTimestamp = lowest;
    c->highestEventTimestamp = highest;
    c->eventsNumber = number;
    c->eventsValidNumber = valid;
}

/* How many events a packet holds, and how many of them are valid. */
static void packet_count(uint8_t *p, int32_t number, int32_t valid) {
    put_i32(p + 20, number);
    put_i32(p + 24, valid);
}

/* The container libcaer puts alone after a timestamp reset (container_generation):
   one slot, a special packet with one TIMESTAMP_RESET event stamped INT32_MAX. */
static struct caer_event_packet_container *timestamp_reset_container(void) {
    struct caer_event_packet_container *c = container_allocate(1);
    uint8_t *p = packet_allocate(SPECIAL_EVENT, 1, SPECIAL_EVENT_BYTES, 4, 0);
    if (c == NULL || p == NULL) { free(c); free(p); return NULL; }
    put_i32(event_at(p, 0), (TIMESTAMP_RESET << 1) | 1);
    put_i32(event_at(p, 0) + 4, INT32_MAX);
    packet_count(p, 1, 1);
    container_set(c, SPECIAL_EVENT, p);
    packets_served[SPECIAL_EVENT]++;
    return c;
}

/* Container k of a session, starting at device time t0_us: a polarity packet (an
   edge at column x, one ON event per row, one invalid event), a special packet every
   25th container (an external-input edge), a frame every other container while the
   APS runs, an IMU sample while the IMU runs; the other slots NULL. */
static struct caer_event_packet_container *data_container(int32_t k, int64_t t0_us, int32_t x,
                                                           int32_t columns, bool aps, bool imu) {
    const int32_t rows = 180, valid_n = rows * columns, n = valid_n + 1;
    const int32_t width = sensor_width_px > 0 ? sensor_width_px : 240;
    struct caer_event_packet_container *c = container_allocate(DAVIS_SLOTS);
    if (c == NULL) return NULL;
    int32_t capacity = n > POLARITY_CAPACITY ? n : POLARITY_CAPACITY;
    uint8_t *pol = packet_allocate(POLARITY_EVENT, capacity, POLARITY_EVENT_BYTES, 4, overflow_of(t0_us));
    if (pol == NULL) { free(c); return NULL; }
    for (int32_t i = 0; i < n; i++) {
        uint8_t *e = event_at(pol, i);
        bool valid = i < valid_n;
        int32_t col = (i / rows) % columns, r = i % rows;
        uint32_t data = ((uint32_t) ((x + col) % width) << 17) | ((uint32_t) r << 2) | 2u | (valid ? 1u : 0u);
        put_i32(e, (int32_t) data);
        put_i32(e + 4, ts31(t0_us + 1000 * col + r));
    }
    packet_count(pol, n, valid_n);
    container_set(c, POLARITY_EVENT, pol);
    packets_served[POLARITY_EVENT]++;
    if (k % 25 == 0) {
        uint8_t *sp = packet_allocate(SPECIAL_EVENT, SPECIAL_CAPACITY, SPECIAL_EVENT_BYTES, 4, overflow_of(t0_us));
        if (sp != NULL) {
            put_i32(event_at(sp, 0), (EXTERNAL_INPUT_RISING_EDGE << 1) | 1);
            put_i32(event_at(sp, 0) + 4, ts31(t0_us + 90));
            packet_count(sp, 1, 1);
            container_set(c, SPECIAL_EVENT, sp);
            packets_served[SPECIAL_EVENT]++;
        }
    }
    if (aps && k % 2 == 0) {
        int32_t pixels = (int32_t) sensor_width_px * (int32_t) sensor_height_px;
        if (pixels <= 0) pixels = 1;
        uint8_t *fp = packet_allocate(FRAME_EVENT, FRAME_CAPACITY, FRAME_EVENT_HEADER_BYTES + 2 * pixels, 8,
                                      overflow_of(t0_us));
        if (fp != NULL) {
            uint8_t *e = event_at(fp, 0);
            put_i32(e, (1 << 1) | 1); /* info: valid, one colour channel */
            for (int f = 1; f <= 4; f++) put_i32(e + 4 * f, ts31(t0_us + 100 * f));
            put_i32(e + 20, sensor_width_px);
            put_i32(e + 24, sensor_height_px);
            /* Pixels: a grey that ON-event readers would misread as events if they
               walked into this packet. */
            memset(e + FRAME_EVENT_HEADER_BYTES, 0x5B, 2 * (size_t) pixels);
            packet_count(fp, 1, 1);
            container_set(c, FRAME_EVENT, fp);
            packets_served[FRAME_EVENT]++;
        }
    }
    if (imu) {
        uint8_t *ip = packet_allocate(IMU6_EVENT, IMU6_CAPACITY, IMU6_EVENT_BYTES, 4, overflow_of(t0_us));
        if (ip != NULL) {
            uint8_t *e = event_at(ip, 0);
            put_i32(e, 1);
            put_i32(e + 4, ts31(t0_us + 500));
            put_f32(e + 8, 0.0f);
            put_f32(e + 12, 0.0f);
            put_f32(e + 16, 1.0f); /* g */
            put_f32(e + 32, 30.0f); /* deg C */
            packet_count(ip, 1, 1);
            container_set(c, IMU6_EVENT, ip);
            packets_served[IMU6_EVENT]++;
        }
    }
    return c;
}

/* Exported for tests of readers: container k as DataGet makes it, with the APS and
   the IMU running (free it as libcaer's are freed). */
struct caer_event_packet_container *caer_mock_container(int32_t k, int64_t t0_us, int32_t x) {
    return data_container(k, t0_us, x, 1, true, true);
}

/* Exported for tests of readers: the container libcaer sends alone after a
   timestamp reset. */
struct caer_event_packet_container *caer_mock_timestamp_reset_container(void) {
    return timestamp_reset_container();
}

static void *notify_shutdown(void *arg) {
    struct caer_device_handle *h = arg;
    /* libcaer's USB thread sees the transfers fail, stops them, then calls back. */
    sleep_until_us(caer_mock_now_us() + 2000);
    atomic_fetch_add(&shutdown_calls, 1);
    if (h->shutdown) h->shutdown(h->shutdown_ptr);
    return NULL;
}

/* The span of device time a container holds: CAER_HOST_CONFIG_PACKETS_MAX_CONTAINER_INTERVAL,
   10000 us unless set (libcaer's default, container_generation.h; measured on 3.3.15:
   about 100 containers a second, 9.2 ms mean span). One edge column per millisecond. */
static int32_t container_columns(void) {
    int64_t interval_us = caer_mock_config_value(HOST_PACKETS, 1);
    if (interval_us < 0) interval_us = 10000;
    int64_t columns = interval_us / 1000;
    return columns < 1 ? 1 : (columns > 100 ? 100 : (int32_t) columns);
}

/* The next container of the session, built now. */
static struct caer_event_packet_container *next_container(struct caer_device_handle *h, int64_t t0_us,
                                                          int32_t columns) {
    int32_t k = h->served;
    bool aps = device_type == 4 && (h->aps_off_from < 0 || k < h->aps_off_from);
    bool imu = h->imu_off_from < 0 || k < h->imu_off_from;
    int32_t x = (k * columns) % (sensor_width_px > 0 ? sensor_width_px : 240);
    struct caer_event_packet_container *c = data_container(k, t0_us, x, columns, aps, imu);
    stream_time_us = t0_us + 1000 * columns;
    h->served++;
    return c;
}

/* The device goes away: transfers stop, libcaer's USB thread calls back a little
   later, and the containers already in the ring buffer are still handed out (as
   libcaer 3.3.15 was seen to) before DataGet returns NULL. */
#define QUEUED_AFTER_UNPLUG 2
static void unplug(struct caer_device_handle *h) {
    atomic_store(&h->transfers, false);
    atomic_store(&vanished, true);
    failed_opens_left = script_failed_opens;
    h->queued_left = QUEUED_AFTER_UNPLUG;
    if (pthread_create(&h->notifier, NULL, notify_shutdown, h) == 0) h->notifier_started = true;
}

struct caer_event_packet_container *caerDeviceDataGet(struct caer_device_handle *h) {
    if (h == NULL || !h->started) return NULL;
    int32_t columns = container_columns();
    if (!atomic_load(&h->transfers)) {
        if (h->queued_left <= 0) return NULL;
        h->queued_left--;
        return next_container(h, stream_time_us, columns);
    }
    if (!h->reset_sent) {
        h->reset_sent = true;
        return timestamp_reset_container();
    }
    if (h->served >= script_before_disconnect) {
        unplug(h);
        return NULL;
    }
    /* Handed out once the device clock has passed the newest valid event, plus USB
       latency. */
    int64_t t0_us = stream_time_us;
    if (quiet_after >= 0 && h->served == quiet_after) t0_us += quiet_us;
    int64_t newest_us = t0_us + 1000 * (columns - 1) + 179;
    int64_t due_us = caer_mock_true_host_us(newest_us) + next_latency_us();
    int64_t now_us = caer_mock_now_us();
    if (due_us > now_us) {
        if (!blocking) return NULL;
        int64_t give_up_us = 1110000 + (int64_t) (next_give_up_rng() % 110001);
        if (due_us - now_us > give_up_us) {
            /* libcaer 3.3.x, measured: 1.11-1.22 s of 1 ms sleeps, then NULL. */
            sleep_until_us(now_us + give_up_us);
            return NULL;
        }
        sleep_until_us(due_us);
    }
    return next_container(h, t0_us, columns);
}
