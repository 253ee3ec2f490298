// Arm semihosting calls (QEMU -semihosting-config target=native): host files.
#ifndef ROBORAY_SEMIHOST_H
#define ROBORAY_SEMIHOST_H
#include <stddef.h>
#include <stdint.h>

// SYS_OPEN modes (index into "r","rb","r+","r+b","w","wb","w+","w+b","a","ab","a+","a+b")
#define SH_MODE_R   (0)
#define SH_MODE_RP  (2)
#define SH_MODE_W   (4)
#define SH_MODE_WP  (6)
#define SH_MODE_A   (8)
#define SH_MODE_AP  (10)

int sh_open(const char *name, size_t name_len, int mode);  // handle, or -1
int sh_close(int h);
size_t sh_write(int h, const void *buf, size_t len);       // bytes written
int sh_read_some(int h, void *buf, size_t len);            // bytes read (0: EOF), -1: error
int sh_seek(int h, uint32_t pos);                          // 0, or -1
int sh_flen(int h);                                        // length, or -1
int sh_remove(const char *name, size_t len);
int sh_rename(const char *from, size_t from_len, const char *to, size_t to_len);
int sh_errno(void);
int sh_system(const char *cmd, size_t len);                // the host shell's exit status
int sh_get_cmdline(char *buf, size_t len);
uint32_t sh_time(void);
void sh_write0(const char *s);
__attribute__((noreturn)) void sh_exit(int status);

extern int sh_stdout;  // handle of ":tt" for writing
#endif
