/*
 * termios2 for programs run under qemu-user (tests only, never shipped).
 *
 * On Linux, Rust's serialport crate sets a port's speed with the termios2 ioctls
 * (TCGETS2 and TCSETS2, serialport 4.10.1 src/posix/termios.rs), which every arm64
 * kernel serves. qemu-user does not translate them (10.0.2: "Inappropriate ioctl for
 * device"; 7.2: "Function not implemented"), so faithd's arm64 build could not open
 * a serial port under emulation. Preloaded into the emulated program
 * (`qemu-aarch64 -E LD_PRELOAD=...`), this turns each termios2 request into the
 * termios one that qemu does translate: the kernel's termios is termios2 without its
 * two speed fields, and a speed becomes the Bnnn code in c_cflag. A speed with no
 * Bnnn code is refused with EINVAL, as the kernel refuses a speed it cannot set.
 */
#define _GNU_SOURCE
#include <asm/ioctls.h>
#include <asm/termbits.h>
#include <dlfcn.h>
#include <errno.h>
#include <stdarg.h>
#include <string.h>

static const struct { speed_t code; unsigned int baud; } speeds[] = {
    {B0, 0}, {B50, 50}, {B75, 75}, {B110, 110}, {B134, 134}, {B150, 150}, {B200, 200},
    {B300, 300}, {B600, 600}, {B1200, 1200}, {B1800, 1800}, {B2400, 2400}, {B4800, 4800},
    {B9600, 9600}, {B19200, 19200}, {B38400, 38400}, {B57600, 57600}, {B115200, 115200},
    {B230400, 230400}, {B460800, 460800}, {B500000, 500000}, {B576000, 576000},
    {B921600, 921600}, {B1000000, 1000000}, {B1152000, 1152000}, {B1500000, 1500000},
    {B2000000, 2000000}, {B2500000, 2500000}, {B3000000, 3000000}, {B3500000, 3500000},
    {B4000000, 4000000},
};

static int (*real_ioctl)(int, unsigned long, void *);

static unsigned int baud_of(speed_t code) {
    for (size_t i = 0; i < sizeof speeds / sizeof speeds[0]; i++)
        if (speeds[i].code == code) return speeds[i].baud;
    return 0;
}

static int code_of(unsigned int baud, speed_t *code) {
    for (size_t i = 0; i < sizeof speeds / sizeof speeds[0]; i++)
        if (speeds[i].baud == baud) { *code = speeds[i].code; return 0; }
    return -1;
}

/* TCSETS2 and its drain/flush variants as the termios request of the same kind. */
static int set_termios2(int fd, unsigned long request, const struct termios2 *t2) {
    struct termios t;
    memcpy(&t, t2, sizeof t);
    if ((t.c_cflag & CBAUD) == BOTHER) {
        speed_t code;
        if (code_of(t2->c_ospeed, &code) != 0) { errno = EINVAL; return -1; }
        t.c_cflag = (t.c_cflag & ~CBAUD) | code;
    }
    unsigned long plain = request == TCSETSW2 ? TCSETSW : request == TCSETSF2 ? TCSETSF : TCSETS;
    return real_ioctl(fd, plain, &t);
}

int ioctl(int fd, unsigned long request, ...) {
    va_list ap;
    va_start(ap, request);
    void *arg = va_arg(ap, void *);
    va_end(ap);
    if (!real_ioctl) real_ioctl = (int (*)(int, unsigned long, void *))dlsym(RTLD_NEXT, "ioctl");
    if (request == TCGETS2) {
        struct termios2 *t2 = arg;
        struct termios t;
        if (real_ioctl(fd, TCGETS, &t) != 0) return -1;
        memset(t2, 0, sizeof *t2);
        memcpy(t2, &t, sizeof t);
        t2->c_ispeed = t2->c_ospeed = baud_of(t.c_cflag & CBAUD);
        return 0;
    }
    if (request == TCSETS2 || request == TCSETSW2 || request == TCSETSF2)
        return set_termios2(fd, request, arg);
    return real_ioctl(fd, request, arg);
}
