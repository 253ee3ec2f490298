// The ROMFS partition, mounted read-only at /rom (see romfs.c).
#ifndef ROBORAY_ROMFS_H
#define ROBORAY_ROMFS_H
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

// Where QEMU loads the image: the AN547's QSPI flash region (8 MB, at
// 0x28000000 in the Non-secure alias); a Pico 2's ROMFS partition is 256 kB.
#define ROMFS_DEFAULT_ADDR       (0x28000000)
#define ROMFS_PARTITION_BYTES    (256 * 1024)
#define ROMFS_MOUNT              "/rom"

#define ROMFS_MISSING (0)
#define ROMFS_FILE    (1)
#define ROMFS_DIR     (2)

typedef struct _romfs_entry_t {
    int kind;              // ROMFS_FILE or ROMFS_DIR
    const uint8_t *data;   // a file's bytes; a directory's records
    size_t len;
} romfs_entry_t;

// 1: mounted; 0: no image at addr; -1: an image that does not fit the partition.
int romfs_mount(uintptr_t addr, size_t partition_bytes);
bool romfs_mounted(void);
size_t romfs_image_bytes(void);
// The part of path after "/rom" ("" or "/..."), or NULL if path is not under /rom
// (or nothing is mounted).
const char *romfs_rel(const char *path);
// ROMFS_MISSING, ROMFS_FILE or ROMFS_DIR, filling *e.
int romfs_lookup(const char *rel, romfs_entry_t *e);
// Iterates a directory's records (*p from e->data to e->data + e->len).
bool romfs_dir_next(const uint8_t **p, const uint8_t *end, romfs_entry_t *e, const char **name, size_t *name_len);
#endif
