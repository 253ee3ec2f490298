// Arm semihosting calls: `bkpt 0xab`, operation in r0, parameter block in r1.
#include <string.h>
#include "semihost.h"

#define SYS_OPEN            (0x01)
#define SYS_CLOSE           (0x02)
#define SYS_WRITE0          (0x04)
#define SYS_WRITE           (0x05)
#define SYS_READ            (0x06)
#define SYS_SEEK            (0x0a)
#define SYS_FLEN            (0x0c)
#define SYS_REMOVE          (0x0e)
#define SYS_RENAME          (0x0f)
#define SYS_TIME            (0x11)
#define SYS_SYSTEM          (0x12)
#define SYS_ERRNO           (0x13)
#define SYS_GET_CMDLINE     (0x15)
#define SYS_EXIT            (0x18)
#define SYS_EXIT_EXTENDED   (0x20)
#define ADP_STOPPED_APPLICATION_EXIT (0x20026)

int sh_stdout = -1;

static inline int sh_call(int op, const void *arg) {
    register int r0 __asm__ ("r0") = op;
    register const void *r1 __asm__ ("r1") = arg;
    __asm__ volatile ("bkpt 0xab" : "+r" (r0) : "r" (r1) : "memory");
    return r0;
}

int sh_open(const char *name, size_t name_len, int mode) {
    uint32_t a[3] = {(uint32_t)name, (uint32_t)mode, (uint32_t)name_len};
    return sh_call(SYS_OPEN, a);
}

int sh_close(int h) {
    uint32_t a[1] = {(uint32_t)h};
    return sh_call(SYS_CLOSE, a);
}

size_t sh_write(int h, const void *buf, size_t len) {
    const char *p = buf;
    size_t done = 0;
    while (done < len) {
        uint32_t a[3] = {(uint32_t)h, (uint32_t)(p + done), (uint32_t)(len - done)};
        int left = sh_call(SYS_WRITE, a);
        if (left < 0 || (size_t)left >= len - done) {
            break;  // error, or nothing written
        }
        done = len - (size_t)left;
    }
    return done;
}

int sh_read_some(int h, void *buf, size_t len) {
    uint32_t a[3] = {(uint32_t)h, (uint32_t)buf, (uint32_t)len};
    int left = sh_call(SYS_READ, a);
    if (left < 0 || (size_t)left > len) {
        return -1;
    }
    return (int)(len - (size_t)left);
}

int sh_seek(int h, uint32_t pos) {
    uint32_t a[2] = {(uint32_t)h, pos};
    return sh_call(SYS_SEEK, a) == 0 ? 0 : -1;
}

int sh_flen(int h) {
    uint32_t a[1] = {(uint32_t)h};
    return sh_call(SYS_FLEN, a);
}

int sh_remove(const char *name, size_t len) {
    uint32_t a[2] = {(uint32_t)name, (uint32_t)len};
    return sh_call(SYS_REMOVE, a);
}

int sh_system(const char *cmd, size_t len) {
    uint32_t a[2] = {(uint32_t)cmd, (uint32_t)len};
    return sh_call(SYS_SYSTEM, a);
}

int sh_rename(const char *from, size_t from_len, const char *to, size_t to_len) {
    uint32_t a[4] = {(uint32_t)from, (uint32_t)from_len, (uint32_t)to, (uint32_t)to_len};
    return sh_call(SYS_RENAME, a);
}

int sh_errno(void) {
    return sh_call(SYS_ERRNO, 0);
}

int sh_get_cmdline(char *buf, size_t len) {
    uint32_t a[2] = {(uint32_t)buf, (uint32_t)len};
    if (sh_call(SYS_GET_CMDLINE, a) != 0) {
        return -1;
    }
    return (int)a[1];
}

uint32_t sh_time(void) {
    return (uint32_t)sh_call(SYS_TIME, 0);
}

void sh_write0(const char *s) {
    sh_call(SYS_WRITE0, s);
}

void sh_exit(int status) {
    uint32_t a[2] = {ADP_STOPPED_APPLICATION_EXIT, (uint32_t)status};
    sh_call(SYS_EXIT_EXTENDED, a);
    // Only if the host lacks SYS_EXIT_EXTENDED: 0 or 1.
    sh_call(SYS_EXIT, (const void *)(status == 0 ? ADP_STOPPED_APPLICATION_EXIT : 0x20024));
    for (;;) {
    }
}
