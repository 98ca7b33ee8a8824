/*
 * usb_standin.c: a USB camera on a pretend bus, for testing faithd under iniVation's
 * REAL libcaer without a camera.
 *
 * What it is. A shared library that defines the libusb-1.0 functions libcaer 3.x
 * calls (the 23 that `nm -D --undefined-only` lists for libcaer 3.3.15, plus
 * libusb_set_option, libusb_set_log_cb and libusb_set_debug, which a libcaer built
 * against libusb 1.0.23 or later also calls). Loaded with LD_PRELOAD ahead of the
 * libusb libcaer links, its definitions are the ones libcaer's calls bind to, so the
 * real libcaer opens, configures and streams from a device that exists only here.
 * It is written from libusb's public API (libusb.h, 1.0.x: the types below are
 * declared from it, and `build.rs` compiles this file once more against the system's
 * libusb.h when that is installed, to hold the declarations to it) and from what
 * libcaer's source (3.3.9) asks of a device; no libcaer code is in it.
 *
 * What it presents, chosen by environment variables read once, when it is loaded:
 *
 *   USB_STANDIN_CAMERA   davis240 (default): a DAVIS240C on an FX2 board, 152a:841b,
 *                        firmware 4, logic 18 patch 1, chip 2, 240x180;
 *                        davis346: a DAVIS346B on an FX3 board, 152a:841a, firmware 6,
 *                        logic 18 patch 1, chip 5, 346x260;
 *                        dvxplorer: 152a:8419, firmware 8, logic 18 patch 2, chip 20,
 *                        640x480; dvxplorer-lite: the same board, chip 19, 320x240;
 *                        none: an empty bus.
 *   USB_STANDIN_FIRMWARE n        bcdDevice's low byte instead of the camera's own.
 *   USB_STANDIN_LOGIC n           the logic version register (SYSINFO 0) instead.
 *   USB_STANDIN_LOGIC_PATCH n     the logic patch register (SYSINFO 7) instead.
 *   USB_STANDIN_FAULT    access: libusb_open fails with LIBUSB_ERROR_ACCESS (no
 *                        permission); busy: libusb_claim_interface fails with
 *                        LIBUSB_ERROR_BUSY (another program holds the camera).
 *   USB_STANDIN_REFUSE   "mod:param[,mod:param...]": a configuration write
 *                        (VR_FPGA_CONFIG, wValue = module, wIndex = parameter) to one
 *                        of these stalls, as a device does a request it refuses.
 *   USB_STANDIN_RATE_HZ  events per second of the scene (default 10000; 0: none).
 *   USB_STANDIN_DARK_MS  "a-b" or "a-": no events from a to b ms (or for ever) after
 *                        each stream start; the clock runs on (wrap words go out).
 *   USB_STANDIN_CLOCK_START_US    the device clock after its timestamp reset (default
 *                        0); 2147000000 crosses the 31-bit wrap 0.48 s in.
 *   USB_STANDIN_UNPLUG_MS T       the camera is unplugged T ms after its first stream
 *                        start: every transfer in flight completes with
 *                        LIBUSB_TRANSFER_NO_DEVICE, every later call on it fails with
 *                        LIBUSB_ERROR_NO_DEVICE, and it is gone from device lists.
 *   USB_STANDIN_REPLUG_MS T2      it is back T2 ms after that first stream start (at a
 *                        new device address, its registers and clock reset).
 *   USB_STANDIN_SERIAL   the serial number string (at most 8 characters).
 *   USB_STANDIN_LOG      a file to append one line to per init (the first one also
 *                        says what the stand-in presents: "load ..."), exit, device
 *                        list, open, close, claim, release, clear-halt, control
 *                        request answered ("control": direction, bRequest, wValue,
 *                        wIndex, length, data bytes, its status, then decoded
 *                        "set M.P=V", "get M.P=V" or "refuse M.P=V"), transfer
 *                        submit (the first submission of each data transfer, and
 *                        every refused one, a refused control request's writes
 *                        decoded as "attempt M.P=V"), cancel, data transfer ended
 *                        otherwise than COMPLETED ("complete ... status=..."),
 *                        timestamp reset ("stream"), unplug and replug. Each line
 *                        starts with the milliseconds since the library loaded,
 *                        then a word naming what happened, then key=value pairs.
 *   USB_STANDIN_EVENTS   a file to append every event the device put on the wire
 *                        to, "t_us x y p" (device time, pixel, 1 = ON), and a line
 *                        "# reset clock_start_us=N" at each timestamp reset.
 *
 * The scene: event k of a stream happens k * 1e6 / RATE_HZ us after the timestamp
 * reset; a bar sweeps one column per millisecond (x = (t / 1000) mod width), the
 * event's row is (37 k) mod height, and its polarity is ON on even sweeps and OFF on
 * odd ones. Events happen only while the DVS runs (and, on a DVXplorer, while the
 * chip is in stream mode); the words go out only while the USB and multiplexer run.
 *
 * What it follows in libcaer 3.3.9 (the newest source at hand; the 3.3.15 binary
 * it is tested with behaves the same in all of this except where the tests say):
 *   - src/usb_utils.c usbDeviceFind, usbDeviceOpen, checkActiveConfigAndClaim: the
 *     device list, the descriptor (VID 0x152A, PID, firmware in bcdDevice's low
 *     byte, iSerialNumber), open, the string descriptor, the active configuration,
 *     claiming interface 0; usbDeviceClose: release, close, exit.
 *   - src/usb_utils.h startupSPIConfigReceive, spiConfigSend, spiConfigReceive,
 *     spiConfigSendMultiple: vendor request VENDOR_REQUEST_FPGA_CONFIG (0xBF, wValue
 *     = module, wIndex = parameter, 4 bytes big-endian) and
 *     VENDOR_REQUEST_FPGA_CONFIG_MULTIPLE (0xC2, wValue = count, 6 bytes each:
 *     module, parameter, value big-endian); synchronously before the USB thread
 *     runs, asynchronously (control transfers completed in handle_events) after.
 *   - src/usb_utils.c usbThreadRun, usbAllocateTransfers,
 *     usbCancelAndDeallocateTransfers, usbDataTransferCallback: 8 bulk IN transfers
 *     of 8192 bytes on endpoint 0x82, handled in libusb_handle_events_timeout;
 *     cancelled ones complete as CANCELLED, those of a vanished device as NO_DEVICE.
 *   - src/davis.c populateDeviceInfo, src/davis_common.h davisCommonInit, and
 *     src/dvxplorer.c populateDeviceInfo, dvXplorerOpen: the SYSINFO, DVS, APS, IMU,
 *     MUX and EXTINPUT registers read at open (sizes, chip ID, clocks, features).
 *   - src/davis.c davisDataStart/davisDataStop, src/dvxplorer.c
 *     dvXplorerDataStart/dvXplorerDataStop: the run bits (MUX 0.0, timestamp 0.1,
 *     DVS 1.3, USB 9.0; DVXplorer chip mode, register 0x3000 of module 5) that start
 *     and stop the stream.
 *   - src/davis_common.h davisCommonEventTranslator and src/dvxplorer.c
 *     dvXplorerEventTranslator with src/timestamps.h: the 16-bit little-endian words
 *     (timestamp: bit 15 and 15 bits of microseconds; code 7: wrap, 2^15 us times
 *     its 12-bit count; code 0 data 1: timestamp reset; DAVIS code 1: row, codes
 *     2/3: column with polarity OFF/ON; DVXplorer code 1: column, code 4: 8-row
 *     group address, codes 3/2: presence mask of group 1/2 with bit 8 set for OFF).
 *
 * What it is not: no APS frames, no IMU samples, no external-input events, no
 * statistics; the device's own register semantics are modelled only for the run
 * bits and the registers libcaer reads; the timing of the wire is approximate (data
 * goes out when a transfer's buffer is full or 1 ms after the first word waiting,
 * the early-packet delay libcaer's default asks for); one camera at most.
 */

#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/time.h>
#include <sys/types.h>
#include <time.h>
#include <unistd.h>

#ifdef USB_STANDIN_SYSTEM_LIBUSB
/* The check build: the same code against the system's libusb.h. */
#include <libusb-1.0/libusb.h>
#else
/* libusb-1.0's public types and constants, declared as libusb.h (1.0.x) declares
 * them; LIBUSB_CALL is empty on Linux. */
typedef struct libusb_context libusb_context;
typedef struct libusb_device libusb_device;
typedef struct libusb_device_handle libusb_device_handle;

enum libusb_error {
	LIBUSB_SUCCESS             = 0,
	LIBUSB_ERROR_IO            = -1,
	LIBUSB_ERROR_INVALID_PARAM = -2,
	LIBUSB_ERROR_ACCESS        = -3,
	LIBUSB_ERROR_NO_DEVICE     = -4,
	LIBUSB_ERROR_NOT_FOUND     = -5,
	LIBUSB_ERROR_BUSY          = -6,
	LIBUSB_ERROR_TIMEOUT       = -7,
	LIBUSB_ERROR_OVERFLOW      = -8,
	LIBUSB_ERROR_PIPE          = -9,
	LIBUSB_ERROR_INTERRUPTED   = -10,
	LIBUSB_ERROR_NO_MEM        = -11,
	LIBUSB_ERROR_NOT_SUPPORTED = -12,
	LIBUSB_ERROR_OTHER         = -99,
};

enum libusb_transfer_status {
	LIBUSB_TRANSFER_COMPLETED,
	LIBUSB_TRANSFER_ERROR,
	LIBUSB_TRANSFER_TIMED_OUT,
	LIBUSB_TRANSFER_CANCELLED,
	LIBUSB_TRANSFER_STALL,
	LIBUSB_TRANSFER_NO_DEVICE,
	LIBUSB_TRANSFER_OVERFLOW,
};

enum libusb_transfer_type {
	LIBUSB_TRANSFER_TYPE_CONTROL     = 0,
	LIBUSB_TRANSFER_TYPE_ISOCHRONOUS = 1,
	LIBUSB_TRANSFER_TYPE_BULK        = 2,
	LIBUSB_TRANSFER_TYPE_INTERRUPT   = 3,
};

enum libusb_transfer_flags {
	LIBUSB_TRANSFER_SHORT_NOT_OK    = 1U << 0,
	LIBUSB_TRANSFER_FREE_BUFFER     = 1U << 1,
	LIBUSB_TRANSFER_FREE_TRANSFER   = 1U << 2,
	LIBUSB_TRANSFER_ADD_ZERO_PACKET = 1U << 3,
};

enum libusb_option { LIBUSB_OPTION_LOG_LEVEL = 0 };
enum libusb_log_level { LIBUSB_LOG_LEVEL_NONE = 0 };
typedef void (*libusb_log_cb)(libusb_context *ctx, enum libusb_log_level level, const char *str);

#define LIBUSB_ENDPOINT_IN         0x80
#define LIBUSB_REQUEST_TYPE_VENDOR (0x02 << 5)
#define LIBUSB_CONTROL_SETUP_SIZE  8

struct libusb_device_descriptor {
	uint8_t bLength;
	uint8_t bDescriptorType;
	uint16_t bcdUSB;
	uint8_t bDeviceClass;
	uint8_t bDeviceSubClass;
	uint8_t bDeviceProtocol;
	uint8_t bMaxPacketSize0;
	uint16_t idVendor;
	uint16_t idProduct;
	uint16_t bcdDevice;
	uint8_t iManufacturer;
	uint8_t iProduct;
	uint8_t iSerialNumber;
	uint8_t bNumConfigurations;
};

struct libusb_iso_packet_descriptor {
	unsigned int length;
	unsigned int actual_length;
	enum libusb_transfer_status status;
};

struct libusb_transfer;
typedef void (*libusb_transfer_cb_fn)(struct libusb_transfer *transfer);

struct libusb_transfer {
	libusb_device_handle *dev_handle;
	uint8_t flags;
	unsigned char endpoint;
	unsigned char type;
	unsigned int timeout;
	enum libusb_transfer_status status;
	int length;
	int actual_length;
	libusb_transfer_cb_fn callback;
	void *user_data;
	unsigned char *buffer;
	int num_iso_packets;
	struct libusb_iso_packet_descriptor iso_packet_desc[];
};
#endif

/* The layout libcaer's binary reads (LP64: x86-64, AArch64); the check build holds
 * libusb.h's own struct to the same offsets. */
#if defined(__LP64__)
_Static_assert(offsetof(struct libusb_transfer, flags) == 8, "libusb_transfer.flags");
_Static_assert(offsetof(struct libusb_transfer, timeout) == 12, "libusb_transfer.timeout");
_Static_assert(offsetof(struct libusb_transfer, status) == 16, "libusb_transfer.status");
_Static_assert(offsetof(struct libusb_transfer, length) == 20, "libusb_transfer.length");
_Static_assert(offsetof(struct libusb_transfer, actual_length) == 24, "libusb_transfer.actual_length");
_Static_assert(offsetof(struct libusb_transfer, callback) == 32, "libusb_transfer.callback");
_Static_assert(offsetof(struct libusb_transfer, user_data) == 40, "libusb_transfer.user_data");
_Static_assert(offsetof(struct libusb_transfer, buffer) == 48, "libusb_transfer.buffer");
_Static_assert(offsetof(struct libusb_transfer, num_iso_packets) == 56, "libusb_transfer.num_iso_packets");
_Static_assert(sizeof(struct libusb_device_descriptor) == 18, "libusb_device_descriptor");
_Static_assert(offsetof(struct libusb_device_descriptor, bcdDevice) == 12, "bcdDevice");
_Static_assert(offsetof(struct libusb_device_descriptor, iSerialNumber) == 16, "iSerialNumber");
#endif

#define EXPORT __attribute__((visibility("default")))

/* The requests and registers libcaer uses (src/usb_utils.h; include/libcaer/devices/
 * davis.h and dvxplorer.h). */
#define VR_FPGA_CONFIG          0xBF
#define VR_FPGA_CONFIG_MULTIPLE 0xC2
#define DATA_ENDPOINT           0x82
#define MOD_MUX                 0
#define MOD_DVS                 1
#define MOD_APS                 2
#define MOD_IMU                 3
#define MOD_EXTINPUT            4
#define MOD_DVX_CHIP_REGISTERS  5
#define MOD_SYSINFO             6
#define MOD_USB                 9
#define DVX_REGISTER_CONTROL_MODE 0x3000
#define DVX_MODE_STREAM           2
/* How long the device lets a partly filled packet wait (libcaer's default early
 * packet delay: 8 x 125 us). */
#define EARLY_PACKET_NS 1000000LL
#define FIFO_BYTES      (4 * 1024 * 1024)

/* ---------------------------------------------------------------- the camera */

struct camera_model {
	const char *name;
	uint16_t pid;
	uint16_t bcd_usb;
	uint8_t firmware;
	uint32_t logic;
	uint32_t logic_patch;
	uint32_t chip_id;
	uint16_t width;
	uint16_t height;
	bool dvxplorer;
	bool fx3;
	const char *serial;
};

static const struct camera_model CAMERAS[] = {
	{"davis240", 0x841B, 0x0200, 4, 18, 1, 2, 240, 180, false, false, "STI00240"},
	{"davis346", 0x841A, 0x0300, 6, 18, 1, 5, 346, 260, false, true, "STI00346"},
	{"dvxplorer", 0x8419, 0x0300, 8, 18, 2, 20, 640, 480, true, true, "STI00640"},
	{"dvxplorer-lite", 0x8419, 0x0300, 8, 18, 2, 19, 320, 240, true, true, "STI00320"},
};

enum fault { FAULT_NONE, FAULT_ACCESS, FAULT_BUSY };

#define MAX_REFUSED 16
#define MAX_REGISTERS 512

struct reg {
	uint16_t mod;
	uint16_t param;
	uint32_t value;
};

struct libusb_context {
	int serial;
	bool is_default;
	int users;
};

/* A device as one context sees it, as libusb has it: counted references, one per
 * device list holding it and per open handle. */
struct libusb_device {
	libusb_context *ctx;
	int generation;
	uint8_t bus;
	uint8_t address;
	int refs;
};

struct libusb_device_handle {
	libusb_device *dev;
	libusb_context *ctx;
	bool claimed;
};

/* A transfer as this library allocates it, as libusb itself does: its own
 * bookkeeping, then (at ITRANSFER_HEAD bytes, aligned) the public struct, which ends
 * in a flexible array. */
struct itransfer {
	struct itransfer *next;
	libusb_context *ctx;
	bool in_flight;
	bool cancelled;
	bool submitted_before;
};

#define ITRANSFER_HEAD \
	((sizeof(struct itransfer) + _Alignof(max_align_t) - 1) / _Alignof(max_align_t) * _Alignof(max_align_t))

static struct libusb_transfer *public_of(struct itransfer *t) {
	return (struct libusb_transfer *) (void *) ((char *) t + ITRANSFER_HEAD);
}

static void unlink_transfer(struct itransfer *t);

static struct {
	pthread_mutex_t lock;
	pthread_cond_t wake;
	int64_t loaded_ns;
	int log_fd;
	int events_fd;

	/* Configuration. */
	const struct camera_model *camera;
	uint8_t firmware;
	uint32_t logic;
	uint32_t logic_patch;
	enum fault fault;
	struct {
		uint16_t mod;
		uint16_t param;
	} refused[MAX_REFUSED];
	int refused_count;
	double rate_hz;
	int64_t dark_from_us;
	int64_t dark_to_us;
	int64_t clock_start_us;
	int64_t unplug_ms;
	int64_t replug_ms;
	char serial[16];

	/* The bus. */
	bool announced;
	struct libusb_context default_ctx;
	int next_ctx_serial;
	int generation;
	uint8_t address;
	libusb_device_handle *claimed_by;
	bool present;
	int64_t first_stream_ns;
	struct itransfer *in_flight;

	/* The device's registers and stream. */
	struct reg regs[MAX_REGISTERS];
	int reg_count;
	bool ts_running;
	int64_t ts_origin_ns;
	uint64_t next_event;
	int64_t wrap_units;
	int64_t current_us;
	uint8_t *fifo;
	size_t fifo_head;
	size_t fifo_len;
	int64_t fifo_since_ns;
	uint64_t dropped_words;
	uint64_t bytes_delivered;
	uint64_t data_completions;
	char *events_buf;
	size_t events_len;
	size_t events_cap;
} S = {
	.lock     = PTHREAD_MUTEX_INITIALIZER,
	.log_fd   = -1,
	.events_fd = -1,
};

static int64_t now_ns(void) {
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (int64_t) ts.tv_sec * 1000000000LL + ts.tv_nsec;
}

/* One line to the log, with the time since load. Called with or without the lock:
 * each line is one write(2) to a file opened O_APPEND. */
__attribute__((format(printf, 1, 2))) static void logf_(const char *format, ...) {
	if (S.log_fd < 0) {
		return;
	}
	char line[1024];
	double ms = (double) (now_ns() - S.loaded_ns) / 1e6;
	int n     = snprintf(line, sizeof(line), "%12.3f ", ms);
	va_list args;
	va_start(args, format);
	int m = vsnprintf(line + n, sizeof(line) - (size_t) n - 1, format, args);
	va_end(args);
	size_t len = (size_t) n + (m < 0 ? 0 : (size_t) m);
	if (len > sizeof(line) - 2) {
		len = sizeof(line) - 2;
	}
	line[len++] = '\n';
	ssize_t written = write(S.log_fd, line, len);
	(void) written;
}

static const char *status_name(enum libusb_transfer_status status) {
	switch (status) {
		case LIBUSB_TRANSFER_COMPLETED:
			return "COMPLETED";
		case LIBUSB_TRANSFER_ERROR:
			return "ERROR";
		case LIBUSB_TRANSFER_TIMED_OUT:
			return "TIMED_OUT";
		case LIBUSB_TRANSFER_CANCELLED:
			return "CANCELLED";
		case LIBUSB_TRANSFER_STALL:
			return "STALL";
		case LIBUSB_TRANSFER_NO_DEVICE:
			return "NO_DEVICE";
		case LIBUSB_TRANSFER_OVERFLOW:
			return "OVERFLOW";
	}
	return "?";
}

static int64_t env_int(const char *name, int64_t fallback) {
	const char *text = getenv(name);
	if (text == NULL || *text == '\0') {
		return fallback;
	}
	return strtoll(text, NULL, 0);
}

__attribute__((constructor)) static void standin_load(void) {
	S.loaded_ns = now_ns();
	pthread_condattr_t attr;
	pthread_condattr_init(&attr);
	pthread_condattr_setclock(&attr, CLOCK_MONOTONIC);
	pthread_cond_init(&S.wake, &attr);
	pthread_condattr_destroy(&attr);

	const char *log = getenv("USB_STANDIN_LOG");
	if (log != NULL && *log != '\0') {
		S.log_fd = open(log, O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
	}
	const char *events = getenv("USB_STANDIN_EVENTS");
	if (events != NULL && *events != '\0') {
		S.events_fd = open(events, O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
	}

	const char *camera = getenv("USB_STANDIN_CAMERA");
	if (camera == NULL || *camera == '\0') {
		camera = "davis240";
	}
	S.camera = NULL;
	for (size_t i = 0; i < sizeof(CAMERAS) / sizeof(CAMERAS[0]); i++) {
		if (strcmp(camera, CAMERAS[i].name) == 0) {
			S.camera = &CAMERAS[i];
		}
	}
	if (S.camera != NULL) {
		S.firmware    = (uint8_t) env_int("USB_STANDIN_FIRMWARE", S.camera->firmware);
		S.logic       = (uint32_t) env_int("USB_STANDIN_LOGIC", S.camera->logic);
		S.logic_patch = (uint32_t) env_int("USB_STANDIN_LOGIC_PATCH", S.camera->logic_patch);
		const char *serial = getenv("USB_STANDIN_SERIAL");
		snprintf(S.serial, sizeof(S.serial), "%s", (serial != NULL) ? serial : S.camera->serial);
	}

	const char *fault = getenv("USB_STANDIN_FAULT");
	if (fault != NULL && strcmp(fault, "access") == 0) {
		S.fault = FAULT_ACCESS;
	}
	else if (fault != NULL && strcmp(fault, "busy") == 0) {
		S.fault = FAULT_BUSY;
	}

	const char *refuse = getenv("USB_STANDIN_REFUSE");
	while (refuse != NULL && *refuse != '\0' && S.refused_count < MAX_REFUSED) {
		char *end;
		long mod = strtol(refuse, &end, 0);
		if (*end != ':') {
			break;
		}
		long param                          = strtol(end + 1, &end, 0);
		S.refused[S.refused_count].mod      = (uint16_t) mod;
		S.refused[S.refused_count++].param  = (uint16_t) param;
		refuse                              = (*end == ',') ? end + 1 : end;
	}

	S.rate_hz        = (double) env_int("USB_STANDIN_RATE_HZ", 10000);
	S.dark_from_us   = -1;
	S.dark_to_us     = -1;
	const char *dark = getenv("USB_STANDIN_DARK_MS");
	if (dark != NULL && *dark != '\0') {
		char *end;
		S.dark_from_us = strtoll(dark, &end, 0) * 1000;
		S.dark_to_us   = (*end == '-' && end[1] != '\0') ? strtoll(end + 1, NULL, 0) * 1000 : INT64_MAX;
	}
	S.clock_start_us = env_int("USB_STANDIN_CLOCK_START_US", 0);
	S.unplug_ms      = env_int("USB_STANDIN_UNPLUG_MS", -1);
	S.replug_ms      = env_int("USB_STANDIN_REPLUG_MS", -1);

	S.default_ctx.is_default = true;
	S.generation = 0;
	S.address    = 5;
	S.present    = S.camera != NULL;

}

/* ------------------------------------------------------ registers (locked) */

static void reset_registers(void) {
	S.reg_count   = 0;
	S.ts_running  = false;
	S.fifo_head   = 0;
	S.fifo_len    = 0;
	S.next_event  = 0;
	S.wrap_units  = 0;
	S.current_us  = 0;
}

static struct reg *find_reg(uint16_t mod, uint16_t param) {
	for (int i = 0; i < S.reg_count; i++) {
		if (S.regs[i].mod == mod && S.regs[i].param == param) {
			return &S.regs[i];
		}
	}
	return NULL;
}

static uint32_t written(uint16_t mod, uint16_t param) {
	struct reg *r = find_reg(mod, param);
	return (r != NULL) ? r->value : 0;
}

/* The registers libcaer reads at open (davis.c populateDeviceInfo,
 * davis_common.h davisCommonInit; dvxplorer.c populateDeviceInfo, dvXplorerOpen);
 * anything else reads back as last written, or 0. */
static uint32_t read_register(uint16_t mod, uint16_t param) {
	const struct camera_model *c = S.camera;
	if (mod == MOD_SYSINFO) {
		switch (param) {
			case 0:
				return S.logic;
			case 1:
				return c->chip_id;
			case 2:
				return 1; /* timestamp master */
			case 3:
				return c->fx3 ? 104 : 30; /* logic clock, MHz */
			case 4:
				return c->fx3 ? 52 : 30; /* ADC clock, MHz */
			case 5:
				return c->fx3 ? 80 : 30; /* USB clock, MHz */
			case 6:
				return 1000; /* clock deviation factor, 1/1000 */
			case 7:
				return S.logic_patch;
			default:
				break;
		}
	}
	if (mod == MOD_DVS) {
		switch (param) {
			case 0:
				return c->width;
			case 1:
				return c->height;
			case 2:
				return 0; /* orientation: no swap, no flip */
			case 10: /* pixel filter */
			case 30: /* background-activity filter */
			case 40: /* ROI filter */
			case 50: /* skip filter */
			case 60: /* polarity filter */
				return c->fx3 && !c->dvxplorer;
			case 80: /* statistics */
				return 0;
			default:
				break;
		}
	}
	if (mod == MOD_APS && !c->dvxplorer) {
		switch (param) {
			case 0:
				return c->width;
			case 1:
				return c->height;
			case 2:
				return 0;
			case 3:
				return 0; /* monochrome */
			case 6:
				return 1; /* global shutter */
			default:
				break;
		}
	}
	if (mod == MOD_IMU) {
		switch (param) {
			case 0:
				return c->dvxplorer ? 3 : 1; /* Bosch BMI160, InvenSense 6050/6150 */
			case 1:
				return 0;
			default:
				break;
		}
	}
	if (mod == MOD_EXTINPUT && param == 10) {
		return c->fx3; /* signal generator */
	}
	if (mod == MOD_MUX && param == 80) {
		return 0; /* statistics */
	}
	return written(mod, param);
}

static bool refused(uint16_t mod, uint16_t param) {
	for (int i = 0; i < S.refused_count; i++) {
		if (S.refused[i].mod == mod && S.refused[i].param == param) {
			return true;
		}
	}
	return false;
}

/* ---------------------------------------------------- the wire (locked) */

static void push_word(uint16_t word) {
	if (S.fifo == NULL) {
		/* Allocated on the first stream: every program a test starts with this
		 * library preloaded loads it. */
		S.fifo = malloc(FIFO_BYTES);
	}
	if (S.fifo == NULL || S.fifo_len + 2 > FIFO_BYTES) {
		S.dropped_words++;
		return;
	}
	if (S.fifo_len == 0) {
		S.fifo_since_ns = now_ns();
	}
	size_t tail            = (S.fifo_head + S.fifo_len) % FIFO_BYTES;
	S.fifo[tail]           = (uint8_t) (word & 0xFF);
	S.fifo[(tail + 1) % FIFO_BYTES] = (uint8_t) (word >> 8);
	S.fifo_len += 2;
}

/* Brings the device clock on the wire up to `t_us`: wrap words (code 7, up to 4095
 * wraps of 2^15 us each), then a timestamp word for the rest, as
 * handleTimestampWrapNewLogic and handleTimestampUpdateNewLogic read them. */
static void clock_to(int64_t t_us, bool exact) {
	int64_t units = t_us >> 15;
	while (S.wrap_units < units) {
		int64_t n = units - S.wrap_units;
		if (n > 0x0FFF) {
			n = 0x0FFF;
		}
		push_word((uint16_t) (0x7000 | n));
		S.wrap_units += n;
		S.current_us = S.wrap_units << 15;
	}
	if (exact && t_us != S.current_us) {
		push_word((uint16_t) (0x8000 | (t_us & 0x7FFF)));
		S.current_us = t_us;
	}
}

static void note_event(int64_t t_us, uint16_t x, uint16_t y, bool on) {
	if (S.events_fd < 0) {
		return;
	}
	if (S.events_cap - S.events_len < 64) {
		size_t cap = (S.events_cap == 0) ? 65536 : S.events_cap * 2;
		char *grown = realloc(S.events_buf, cap);
		if (grown == NULL) {
			return;
		}
		S.events_buf = grown;
		S.events_cap = cap;
	}
	S.events_len += (size_t) snprintf(S.events_buf + S.events_len, S.events_cap - S.events_len,
		"%lld %u %u %d\n", (long long) t_us, x, y, on ? 1 : 0);
}

static void flush_events(void) {
	if (S.events_fd >= 0 && S.events_len > 0) {
		ssize_t done = write(S.events_fd, S.events_buf, S.events_len);
		(void) done;
	}
	S.events_len = 0;
}

static void encode_event(int64_t t_us, uint16_t x, uint16_t y, bool on) {
	clock_to(t_us, true);
	if (S.camera->dvxplorer) {
		/* Column, then the 8-row group of group 1 (group 2 at offset 0), then group
		 * 1's presence mask with the polarity in bit 8 (set: OFF). */
		push_word((uint16_t) (0x1000 | (x & 0x03FF)));
		push_word((uint16_t) (0x4000 | ((y / 8) & 0x003F)));
		push_word((uint16_t) (0x3000 | (on ? 0 : 0x0100) | (1U << (y % 8))));
	}
	else {
		/* Row, then column with the polarity in the code (3: ON, 2: OFF). */
		push_word((uint16_t) (0x1000 | (y & 0x0FFF)));
		push_word((uint16_t) ((on ? 0x3000 : 0x2000) | (x & 0x0FFF)));
	}
	note_event(t_us, x, y, on);
}

static bool dvs_running(void) {
	bool dvs = written(MOD_DVS, 3) != 0;
	if (S.camera->dvxplorer) {
		dvs = dvs && written(MOD_DVX_CHIP_REGISTERS, DVX_REGISTER_CONTROL_MODE) == DVX_MODE_STREAM;
	}
	return dvs;
}

static bool output_running(void) {
	return S.ts_running && written(MOD_MUX, 0) != 0 && written(MOD_USB, 0) != 0;
}

/* The timestamp generator restarts: a reset word, then the clock brought to its
 * start (long wraps). */
static void timestamp_reset(int64_t now) {
	S.ts_origin_ns = now;
	S.next_event   = 0;
	S.wrap_units   = 0;
	S.current_us   = 0;
	push_word(0x0001);
	clock_to(S.clock_start_us, false);
	if (S.events_fd >= 0) {
		char line[64];
		int n       = snprintf(line, sizeof(line), "# reset clock_start_us=%lld\n", (long long) S.clock_start_us);
		ssize_t out = write(S.events_fd, line, (size_t) n);
		(void) out;
	}
	logf_("stream timestamp-reset clock_start_us=%lld", (long long) S.clock_start_us);
}

/* Everything the device did up to `now`: the scene's events while the DVS and the
 * output run, and the wrap words of a clock that runs on. */
static void generate(int64_t now) {
	if (!S.present || S.camera == NULL || !output_running()) {
		return;
	}
	int64_t rel_now_us = (now - S.ts_origin_ns) / 1000;
	bool dvs           = dvs_running();
	if (S.rate_hz > 0) {
		for (;;) {
			int64_t rel_us = (int64_t) ((double) S.next_event * 1e6 / S.rate_hz);
			if (rel_us > rel_now_us) {
				break;
			}
			uint64_t k = S.next_event++;
			bool dark  = rel_us >= S.dark_from_us && rel_us < S.dark_to_us;
			if (!dvs || dark) {
				continue;
			}
			int64_t sweep = rel_us / 1000;
			uint16_t x    = (uint16_t) (sweep % S.camera->width);
			uint16_t y    = (uint16_t) ((37 * k) % S.camera->height);
			bool on       = ((sweep / S.camera->width) % 2) == 0;
			encode_event(S.clock_start_us + rel_us, x, y, on);
		}
	}
	/* A clock with nothing to say sends only its wraps. */
	clock_to(S.clock_start_us + rel_now_us, false);
	flush_events();
}

/* Applies a register write (the device side of spiConfigSend). */
static void write_register(uint16_t mod, uint16_t param, uint32_t value) {
	int64_t now = now_ns();
	/* What happened under the old settings happened first. */
	generate(now);
	struct reg *r = find_reg(mod, param);
	if (r == NULL && S.reg_count < MAX_REGISTERS) {
		r        = &S.regs[S.reg_count++];
		r->mod   = mod;
		r->param = param;
	}
	if (r != NULL) {
		r->value = value;
	}
	if (mod == MOD_MUX && param == 1) {
		if (value != 0 && !S.ts_running) {
			S.ts_running = true;
			if (S.first_stream_ns == 0) {
				S.first_stream_ns = now;
			}
			S.fifo_head = 0;
			S.fifo_len  = 0;
			timestamp_reset(now);
		}
		else if (value == 0) {
			S.ts_running = false;
		}
	}
	if (mod == MOD_MUX && param == 2 && value != 0 && S.ts_running) {
		timestamp_reset(now);
	}
}

/* -------------------------------------------------------- the bus (locked) */

static bool gone(const libusb_device *dev) {
	return !S.present || dev->generation != S.generation;
}

static void unref(libusb_device *dev) {
	if (--dev->refs <= 0) {
		free(dev);
	}
}

/* Unplug and replug, on the clock of the first stream start. */
static void plug_events(int64_t now) {
	if (S.camera == NULL || S.first_stream_ns == 0) {
		return;
	}
	int64_t since_ms = (now - S.first_stream_ns) / 1000000;
	if (S.present && S.generation == 0 && S.unplug_ms >= 0 && since_ms >= S.unplug_ms) {
		S.present = false;
		logf_("unplug address=%u", S.address);
	}
	if (!S.present && S.generation == 0 && S.replug_ms >= 0 && since_ms >= S.replug_ms) {
		/* Enumerated afresh: a new device at the next address. */
		S.generation = 1;
		S.address++;
		S.present = true;
		reset_registers();
		logf_("replug address=%u", S.address);
	}
}

/* ---------------------------------------------------------- control requests */

static void hex(char *out, size_t room, const unsigned char *data, size_t n) {
	size_t used = 0;
	out[0]      = '\0';
	for (size_t i = 0; i < n && used + 3 < room; i++) {
		used += (size_t) snprintf(out + used, room - used, "%02x", data[i]);
	}
}

static uint32_t be32(const unsigned char *p) {
	return ((uint32_t) p[0] << 24) | ((uint32_t) p[1] << 16) | ((uint32_t) p[2] << 8) | (uint32_t) p[3];
}

/* The device's answer to one control request: the transfer status, and for IN the
 * bytes written to `data`. */
static enum libusb_transfer_status control(const libusb_device_handle *handle, uint8_t request_type,
	uint8_t request, uint16_t value, uint16_t index, unsigned char *data, uint16_t length, int *actual) {
	*actual                            = 0;
	bool in                            = (request_type & LIBUSB_ENDPOINT_IN) != 0;
	enum libusb_transfer_status status = LIBUSB_TRANSFER_STALL;
	char decoded[512]                  = "";
	char bytes[160];

	if (gone(handle->dev)) {
		status = LIBUSB_TRANSFER_NO_DEVICE;
	}
	else if ((request_type & 0x60) != LIBUSB_REQUEST_TYPE_VENDOR) {
		status = LIBUSB_TRANSFER_STALL;
	}
	else if (request == VR_FPGA_CONFIG && length == 4) {
		if (in) {
			uint32_t v = read_register(value, index);
			data[0]    = (unsigned char) (v >> 24);
			data[1]    = (unsigned char) (v >> 16);
			data[2]    = (unsigned char) (v >> 8);
			data[3]    = (unsigned char) v;
			*actual    = 4;
			status     = LIBUSB_TRANSFER_COMPLETED;
			snprintf(decoded, sizeof(decoded), " get %u.%u=%u", value, index, v);
		}
		else if (refused(value, index)) {
			status = LIBUSB_TRANSFER_STALL;
			snprintf(decoded, sizeof(decoded), " refuse %u.%u=%u", value, index, be32(data));
		}
		else {
			write_register(value, index, be32(data));
			*actual = 4;
			status  = LIBUSB_TRANSFER_COMPLETED;
			snprintf(decoded, sizeof(decoded), " set %u.%u=%u", value, index, be32(data));
		}
	}
	else if (request == VR_FPGA_CONFIG_MULTIPLE && !in && length == 6U * value) {
		status      = LIBUSB_TRANSFER_COMPLETED;
		size_t used = 0;
		for (uint16_t i = 0; i < value; i++) {
			const unsigned char *e = data + 6 * i;
			bool no                = refused(e[0], e[1]);
			if (no) {
				status = LIBUSB_TRANSFER_STALL;
			}
			else {
				write_register(e[0], e[1], be32(e + 2));
			}
			used += (size_t) snprintf(decoded + used, sizeof(decoded) - used, " %s %u.%u=%u",
				no ? "refuse" : "set", e[0], e[1], be32(e + 2));
			if (used >= sizeof(decoded)) {
				break;
			}
		}
		if (status == LIBUSB_TRANSFER_COMPLETED) {
			*actual = length;
		}
	}
	hex(bytes, sizeof(bytes), data, (in && *actual > 0) ? (size_t) *actual : (in ? 0 : length));
	logf_("control dir=%s bRequest=0x%02x wValue=%u wIndex=%u wLength=%u data=%s status=%s%s", in ? "in" : "out",
		request, value, index, length, bytes[0] ? bytes : "-", status_name(status), decoded);
	return status;
}

/* The register writes a control transfer's setup and data carry, as " attempt
 * M.P=V" words: what a refused submission would have written. */
static void describe_writes(const unsigned char *setup, char *out, size_t room) {
	uint16_t value         = (uint16_t) (setup[2] | (setup[3] << 8));
	uint16_t index         = (uint16_t) (setup[4] | (setup[5] << 8));
	uint16_t length        = (uint16_t) (setup[6] | (setup[7] << 8));
	const unsigned char *d = setup + LIBUSB_CONTROL_SETUP_SIZE;
	out[0]                 = '\0';
	if ((setup[0] & LIBUSB_ENDPOINT_IN) != 0) {
		return;
	}
	if (setup[1] == VR_FPGA_CONFIG && length == 4) {
		snprintf(out, room, " attempt %u.%u=%u", value, index, be32(d));
	}
	else if (setup[1] == VR_FPGA_CONFIG_MULTIPLE && length == 6U * value) {
		size_t used = 0;
		for (uint16_t i = 0; i < value && used < room; i++) {
			used += (size_t) snprintf(
				out + used, room - used, " attempt %u.%u=%u", d[6 * i], d[6 * i + 1], be32(d + 6 * i + 2));
		}
	}
}

/* ------------------------------------------------------------- libusb: core */

EXPORT int libusb_init(libusb_context **ctx) {
	pthread_mutex_lock(&S.lock);
	libusb_context *c;
	if (ctx == NULL) {
		c = &S.default_ctx;
	}
	else {
		c = calloc(1, sizeof(*c));
		if (c == NULL) {
			pthread_mutex_unlock(&S.lock);
			return LIBUSB_ERROR_NO_MEM;
		}
		*ctx = c;
	}
	if (!S.announced) {
		/* Said at the first call, not at load: LD_PRELOAD loads this into every
		 * program a test starts, most of which never touch USB. */
		S.announced = true;
		logf_("load camera=%s firmware=%u logic=%u patch=%u fault=%s refused=%d rate_hz=%.0f clock_start_us=%lld "
			  "unplug_ms=%lld replug_ms=%lld",
			(S.camera != NULL) ? S.camera->name : "none", S.firmware, S.logic, S.logic_patch,
			(S.fault == FAULT_ACCESS) ? "access" : (S.fault == FAULT_BUSY) ? "busy" : "none", S.refused_count,
			S.rate_hz, (long long) S.clock_start_us, (long long) S.unplug_ms, (long long) S.replug_ms);
	}
	c->users++;
	c->serial = (c->serial == 0) ? ++S.next_ctx_serial : c->serial;
	logf_("init ctx=%d%s", c->serial, c->is_default ? " default" : "");
	pthread_mutex_unlock(&S.lock);
	return LIBUSB_SUCCESS;
}

EXPORT void libusb_exit(libusb_context *ctx) {
	pthread_mutex_lock(&S.lock);
	libusb_context *c = (ctx == NULL) ? &S.default_ctx : ctx;
	logf_("exit ctx=%d", c->serial);
	if (--c->users <= 0 && !c->is_default) {
		free(c);
	}
	pthread_mutex_unlock(&S.lock);
}

EXPORT void libusb_set_debug(libusb_context *ctx, int level) {
	(void) ctx;
	(void) level;
}

EXPORT void libusb_set_log_cb(libusb_context *ctx, libusb_log_cb cb, int mode) {
	(void) ctx;
	(void) cb;
	(void) mode;
}

EXPORT int libusb_set_option(libusb_context *ctx, enum libusb_option option, ...) {
	(void) ctx;
	(void) option;
	return LIBUSB_SUCCESS;
}

EXPORT const char *libusb_strerror(int errcode) {
	switch (errcode) {
		case LIBUSB_SUCCESS:
			return "Success";
		case LIBUSB_ERROR_IO:
			return "Input/Output Error";
		case LIBUSB_ERROR_INVALID_PARAM:
			return "Invalid parameter";
		case LIBUSB_ERROR_ACCESS:
			return "Access denied (insufficient permissions)";
		case LIBUSB_ERROR_NO_DEVICE:
			return "No such device (it may have been disconnected)";
		case LIBUSB_ERROR_NOT_FOUND:
			return "Entity not found";
		case LIBUSB_ERROR_BUSY:
			return "Resource busy";
		case LIBUSB_ERROR_TIMEOUT:
			return "Operation timed out";
		case LIBUSB_ERROR_OVERFLOW:
			return "Overflow";
		case LIBUSB_ERROR_PIPE:
			return "Pipe error";
		case LIBUSB_ERROR_NO_MEM:
			return "Insufficient memory";
		default:
			return "Other error";
	}
}

/* ---------------------------------------------------------- libusb: devices */

EXPORT ssize_t libusb_get_device_list(libusb_context *ctx, libusb_device ***list) {
	pthread_mutex_lock(&S.lock);
	plug_events(now_ns());
	libusb_device **result = calloc(2, sizeof(*result));
	libusb_device *dev     = (S.present && result != NULL) ? calloc(1, sizeof(*dev)) : NULL;
	if (result == NULL || (S.present && dev == NULL)) {
		free(result);
		pthread_mutex_unlock(&S.lock);
		return LIBUSB_ERROR_NO_MEM;
	}
	if (dev != NULL) {
		dev->ctx        = (ctx == NULL) ? &S.default_ctx : ctx;
		dev->generation = S.generation;
		dev->bus        = 1;
		dev->address    = S.address;
		dev->refs       = 1;
	}
	result[0] = dev;
	*list     = result;
	logf_("device-list count=%d", dev != NULL);
	pthread_mutex_unlock(&S.lock);
	return (dev != NULL) ? 1 : 0;
}

EXPORT void libusb_free_device_list(libusb_device **list, int unref_devices) {
	if (list == NULL) {
		return;
	}
	pthread_mutex_lock(&S.lock);
	for (libusb_device **d = list; unref_devices && *d != NULL; d++) {
		unref(*d);
	}
	pthread_mutex_unlock(&S.lock);
	free(list);
}

EXPORT int libusb_get_device_descriptor(libusb_device *dev, struct libusb_device_descriptor *desc) {
	(void) dev;
	memset(desc, 0, sizeof(*desc));
	desc->bLength            = 18;
	desc->bDescriptorType    = 1;
	desc->bcdUSB             = S.camera->bcd_usb;
	desc->bDeviceClass       = 0xFF;
	desc->bMaxPacketSize0    = 64;
	desc->idVendor           = 0x152A;
	desc->idProduct          = S.camera->pid;
	desc->bcdDevice          = S.firmware;
	desc->iManufacturer      = 1;
	desc->iProduct           = 2;
	desc->iSerialNumber      = 3;
	desc->bNumConfigurations = 1;
	return LIBUSB_SUCCESS;
}

EXPORT uint8_t libusb_get_bus_number(libusb_device *dev) {
	return dev->bus;
}

EXPORT uint8_t libusb_get_device_address(libusb_device *dev) {
	return dev->address;
}

EXPORT int libusb_open(libusb_device *dev, libusb_device_handle **dev_handle) {
	pthread_mutex_lock(&S.lock);
	plug_events(now_ns());
	int result = LIBUSB_SUCCESS;
	if (gone(dev)) {
		result = LIBUSB_ERROR_NO_DEVICE;
	}
	else if (S.fault == FAULT_ACCESS) {
		result = LIBUSB_ERROR_ACCESS;
	}
	else {
		libusb_device_handle *h = calloc(1, sizeof(*h));
		if (h == NULL) {
			result = LIBUSB_ERROR_NO_MEM;
		}
		else {
			h->dev = dev;
			h->ctx = dev->ctx;
			dev->refs++;
			*dev_handle = h;
		}
	}
	logf_("open address=%u result=%d", dev->address, result);
	pthread_mutex_unlock(&S.lock);
	return result;
}

EXPORT void libusb_close(libusb_device_handle *dev_handle) {
	pthread_mutex_lock(&S.lock);
	logf_("close address=%u data_completions=%llu bytes=%llu dropped_words=%llu", dev_handle->dev->address,
		(unsigned long long) S.data_completions, (unsigned long long) S.bytes_delivered,
		(unsigned long long) S.dropped_words);
	if (S.claimed_by == dev_handle) {
		S.claimed_by = NULL;
	}
	/* A transfer still in flight on a closed handle would complete into freed
	 * memory: it is dropped (libusb leaves this undefined; libcaer never does it). */
	for (struct itransfer *t = S.in_flight, *next; t != NULL; t = next) {
		next = t->next;
		if (public_of(t)->dev_handle == dev_handle) {
			logf_("dropped endpoint=0x%02x in flight at close", public_of(t)->endpoint);
			unlink_transfer(t);
		}
	}
	unref(dev_handle->dev);
	free(dev_handle);
	pthread_mutex_unlock(&S.lock);
}

EXPORT libusb_device *libusb_get_device(libusb_device_handle *dev_handle) {
	return dev_handle->dev;
}

EXPORT int libusb_get_configuration(libusb_device_handle *dev, int *config) {
	pthread_mutex_lock(&S.lock);
	int result = gone(dev->dev) ? LIBUSB_ERROR_NO_DEVICE : LIBUSB_SUCCESS;
	*config    = 1;
	pthread_mutex_unlock(&S.lock);
	return result;
}

EXPORT int libusb_set_configuration(libusb_device_handle *dev_handle, int configuration) {
	pthread_mutex_lock(&S.lock);
	int result = gone(dev_handle->dev) ? LIBUSB_ERROR_NO_DEVICE : LIBUSB_SUCCESS;
	logf_("set-configuration value=%d result=%d", configuration, result);
	pthread_mutex_unlock(&S.lock);
	return result;
}

EXPORT int libusb_claim_interface(libusb_device_handle *dev_handle, int interface_number) {
	pthread_mutex_lock(&S.lock);
	int result = LIBUSB_SUCCESS;
	if (gone(dev_handle->dev)) {
		result = LIBUSB_ERROR_NO_DEVICE;
	}
	else if (S.fault == FAULT_BUSY
			 || (S.claimed_by != NULL && S.claimed_by != dev_handle && !gone(S.claimed_by->dev))) {
		result = LIBUSB_ERROR_BUSY;
	}
	else {
		dev_handle->claimed = true;
		S.claimed_by        = dev_handle;
	}
	logf_("claim interface=%d result=%d", interface_number, result);
	pthread_mutex_unlock(&S.lock);
	return result;
}

EXPORT int libusb_release_interface(libusb_device_handle *dev_handle, int interface_number) {
	pthread_mutex_lock(&S.lock);
	int result = LIBUSB_SUCCESS;
	if (!dev_handle->claimed) {
		result = LIBUSB_ERROR_NOT_FOUND;
	}
	else {
		dev_handle->claimed = false;
		S.claimed_by        = NULL;
		if (gone(dev_handle->dev)) {
			result = LIBUSB_ERROR_NO_DEVICE;
		}
	}
	logf_("release interface=%d result=%d", interface_number, result);
	pthread_mutex_unlock(&S.lock);
	return result;
}

EXPORT int libusb_clear_halt(libusb_device_handle *dev_handle, unsigned char endpoint) {
	pthread_mutex_lock(&S.lock);
	int result = gone(dev_handle->dev) ? LIBUSB_ERROR_NO_DEVICE : LIBUSB_SUCCESS;
	if (result == LIBUSB_SUCCESS && endpoint == DATA_ENDPOINT) {
		S.fifo_head = 0;
		S.fifo_len  = 0;
	}
	logf_("clear-halt endpoint=0x%02x result=%d", endpoint, result);
	pthread_mutex_unlock(&S.lock);
	return result;
}

EXPORT int libusb_get_string_descriptor_ascii(
	libusb_device_handle *dev_handle, uint8_t desc_index, unsigned char *data, int length) {
	pthread_mutex_lock(&S.lock);
	int result;
	if (gone(dev_handle->dev)) {
		result = LIBUSB_ERROR_NO_DEVICE;
	}
	else if (desc_index != 3) {
		result = LIBUSB_ERROR_PIPE;
	}
	else {
		int n = (int) strlen(S.serial);
		if (n > length - 1) {
			n = length - 1;
		}
		memcpy(data, S.serial, (size_t) n);
		data[n] = '\0';
		result  = n;
	}
	logf_("string-descriptor index=%u result=%d", desc_index, result);
	pthread_mutex_unlock(&S.lock);
	return result;
}

EXPORT int libusb_control_transfer(libusb_device_handle *dev_handle, uint8_t request_type, uint8_t bRequest,
	uint16_t wValue, uint16_t wIndex, unsigned char *data, uint16_t wLength, unsigned int timeout) {
	(void) timeout;
	pthread_mutex_lock(&S.lock);
	plug_events(now_ns());
	int actual                         = 0;
	enum libusb_transfer_status status = control(dev_handle, request_type, bRequest, wValue, wIndex, data, wLength,
		&actual);
	pthread_mutex_unlock(&S.lock);
	switch (status) {
		case LIBUSB_TRANSFER_COMPLETED:
			return actual;
		case LIBUSB_TRANSFER_NO_DEVICE:
			return LIBUSB_ERROR_NO_DEVICE;
		default:
			return LIBUSB_ERROR_PIPE;
	}
}

/* -------------------------------------------------------- libusb: transfers */

static struct itransfer *outer(struct libusb_transfer *t) {
	return (struct itransfer *) (void *) ((char *) t - ITRANSFER_HEAD);
}

EXPORT struct libusb_transfer *libusb_alloc_transfer(int iso_packets) {
	size_t extra        = (iso_packets > 0) ? (size_t) iso_packets * sizeof(struct libusb_iso_packet_descriptor) : 0;
	struct itransfer *t = calloc(1, ITRANSFER_HEAD + sizeof(struct libusb_transfer) + extra);
	if (t == NULL) {
		return NULL;
	}
	public_of(t)->num_iso_packets = iso_packets;
	return public_of(t);
}

static void unlink_transfer(struct itransfer *t) {
	for (struct itransfer **p = &S.in_flight; *p != NULL; p = &(*p)->next) {
		if (*p == t) {
			*p = t->next;
			break;
		}
	}
	t->next      = NULL;
	t->in_flight = false;
}

EXPORT void libusb_free_transfer(struct libusb_transfer *transfer) {
	if (transfer == NULL) {
		return;
	}
	struct itransfer *t = outer(transfer);
	pthread_mutex_lock(&S.lock);
	if (t->in_flight) {
		unlink_transfer(t);
	}
	pthread_mutex_unlock(&S.lock);
	if ((transfer->flags & LIBUSB_TRANSFER_FREE_BUFFER) != 0) {
		free(transfer->buffer);
	}
	free(t);
}

static const char *type_name(unsigned char type) {
	switch (type) {
		case LIBUSB_TRANSFER_TYPE_CONTROL:
			return "control";
		case LIBUSB_TRANSFER_TYPE_BULK:
			return "bulk";
		case LIBUSB_TRANSFER_TYPE_INTERRUPT:
			return "interrupt";
		default:
			return "isochronous";
	}
}

EXPORT int libusb_submit_transfer(struct libusb_transfer *transfer) {
	struct itransfer *t = outer(transfer);
	pthread_mutex_lock(&S.lock);
	plug_events(now_ns());
	int result = LIBUSB_SUCCESS;
	if (t->in_flight) {
		result = LIBUSB_ERROR_BUSY;
	}
	else if (gone(transfer->dev_handle->dev)) {
		result = LIBUSB_ERROR_NO_DEVICE;
	}
	else {
		t->ctx       = transfer->dev_handle->ctx;
		t->in_flight = true;
		t->cancelled = false;
		t->next      = NULL;
		struct itransfer **p = &S.in_flight;
		while (*p != NULL) {
			p = &(*p)->next;
		}
		*p = t;
		pthread_cond_broadcast(&S.wake);
	}
	/* Control transfers are logged as requests when the device answers them; data
	 * transfers on their first submission (libcaer resubmits each one as it
	 * completes), and every refused submission. */
	if ((transfer->type != LIBUSB_TRANSFER_TYPE_CONTROL && !t->submitted_before) || result != LIBUSB_SUCCESS) {
		char attempted[256] = "";
		if (transfer->type == LIBUSB_TRANSFER_TYPE_CONTROL) {
			describe_writes(transfer->buffer, attempted, sizeof(attempted));
		}
		logf_("submit endpoint=0x%02x type=%s length=%d result=%d%s", transfer->endpoint, type_name(transfer->type),
			transfer->length, result, attempted);
	}
	if (result == LIBUSB_SUCCESS) {
		t->submitted_before = true;
	}
	pthread_mutex_unlock(&S.lock);
	return result;
}

EXPORT int libusb_cancel_transfer(struct libusb_transfer *transfer) {
	struct itransfer *t = outer(transfer);
	pthread_mutex_lock(&S.lock);
	int result = LIBUSB_SUCCESS;
	if (!t->in_flight || t->cancelled) {
		result = LIBUSB_ERROR_NOT_FOUND;
	}
	else {
		t->cancelled = true;
		pthread_cond_broadcast(&S.wake);
		logf_("cancel endpoint=0x%02x type=%s", transfer->endpoint, type_name(transfer->type));
	}
	pthread_mutex_unlock(&S.lock);
	return result;
}

/* Decides the transfers of `ctx` that are done now, in submission order; moves them
 * to `done` (at most `room`). Locked. */
static int collect(libusb_context *ctx, int64_t now, struct itransfer **done, int room) {
	plug_events(now);
	generate(now);
	int n = 0;
	for (struct itransfer *t = S.in_flight, *next; t != NULL && n < room; t = next) {
		next                       = t->next;
		struct libusb_transfer *pub = public_of(t);
		if (t->ctx != ctx) {
			continue;
		}
		bool finished = true;
		if (gone(pub->dev_handle->dev)) {
			pub->status        = LIBUSB_TRANSFER_NO_DEVICE;
			pub->actual_length = 0;
		}
		else if (t->cancelled) {
			pub->status        = LIBUSB_TRANSFER_CANCELLED;
			pub->actual_length = 0;
		}
		else if (pub->type == LIBUSB_TRANSFER_TYPE_CONTROL) {
			unsigned char *setup = pub->buffer;
			uint16_t value       = (uint16_t) (setup[2] | (setup[3] << 8));
			uint16_t index       = (uint16_t) (setup[4] | (setup[5] << 8));
			uint16_t length      = (uint16_t) (setup[6] | (setup[7] << 8));
			int actual           = 0;
			pub->status          = control(pub->dev_handle, setup[0], setup[1], value, index,
						 setup + LIBUSB_CONTROL_SETUP_SIZE, length, &actual);
			pub->actual_length = actual;
		}
		else if (pub->endpoint == DATA_ENDPOINT && written(MOD_USB, 0) != 0 && S.fifo_len > 0
				 && (S.fifo_len >= (size_t) pub->length || now - S.fifo_since_ns >= EARLY_PACKET_NS)) {
			size_t take = S.fifo_len < (size_t) pub->length ? S.fifo_len : (size_t) pub->length & ~(size_t) 1;
			for (size_t i = 0; i < take; i++) {
				pub->buffer[i] = S.fifo[(S.fifo_head + i) % FIFO_BYTES];
			}
			S.fifo_head = (S.fifo_head + take) % FIFO_BYTES;
			S.fifo_len -= take;
			S.fifo_since_ns    = now;
			pub->status        = LIBUSB_TRANSFER_COMPLETED;
			pub->actual_length = (int) take;
			S.bytes_delivered += take;
			S.data_completions++;
		}
		else {
			finished = false;
		}
		if (finished) {
			unlink_transfer(t);
			done[n++] = t;
			if (pub->type != LIBUSB_TRANSFER_TYPE_CONTROL && pub->status != LIBUSB_TRANSFER_COMPLETED) {
				logf_("complete endpoint=0x%02x type=%s status=%s", pub->endpoint, type_name(pub->type),
					status_name(pub->status));
			}
		}
	}
	return n;
}

EXPORT int libusb_handle_events_timeout(libusb_context *ctx, struct timeval *tv) {
	libusb_context *c  = (ctx == NULL) ? &S.default_ctx : ctx;
	int64_t start      = now_ns();
	int64_t timeout_ns = (tv != NULL) ? (int64_t) tv->tv_sec * 1000000000LL + (int64_t) tv->tv_usec * 1000 : 0;
	int64_t deadline   = start + timeout_ns;
	struct itransfer *done[64];
	int n = 0;

	pthread_mutex_lock(&S.lock);
	for (;;) {
		int64_t now = now_ns();
		n           = collect(c, now, done, 64);
		if (n > 0 || now >= deadline) {
			break;
		}
		/* The device's clock ticks on: look again within a millisecond. */
		int64_t until = now + 1000000;
		if (until > deadline) {
			until = deadline;
		}
		struct timespec ts = {.tv_sec = until / 1000000000LL, .tv_nsec = until % 1000000000LL};
		pthread_cond_timedwait(&S.wake, &S.lock, &ts);
	}
	pthread_mutex_unlock(&S.lock);

	for (int i = 0; i < n; i++) {
		struct libusb_transfer *pub = public_of(done[i]);
		bool free_it               = (pub->flags & LIBUSB_TRANSFER_FREE_TRANSFER) != 0;
		if (pub->callback != NULL) {
			pub->callback(pub);
		}
		if (free_it) {
			libusb_free_transfer(pub);
		}
	}
	return LIBUSB_SUCCESS;
}
