// The ROMFS partition: a MicroPython ROMFS image (as `mpremote romfs deploy`
// writes it to a Pico 2's 256 kB "ROMFS" flash partition) that QEMU loads
// into the AN547's QSPI flash region, mounted read-only at /rom.
//
// Our own reader of the format `mpremote.romfs.VfsRomWriter` writes. Every
// record is  uint(kind) uint(length) payload  with uint a big-endian base-128
// number (bit 7 set on all bytes but the last). The image is one record of
// kind 0x14a6b1 (encoded d2 cd 31) whose payload is the root directory's
// records. A directory record's payload is  uint(name length) name records;
// a file record's is  uint(name length) name  then a data record: kind 2
// (the bytes themselves) or kind 3 (uint(length) uint(offset from the start
// of the image)). Kinds 0 and 1 (unused, padding) and unknown kinds are
// skipped.
#include <string.h>

#include "py/mperrno.h"
#include "romfs.h"

#define KIND_DATA_VERBATIM (2)
#define KIND_DATA_POINTER  (3)
#define KIND_DIRECTORY     (4)
#define KIND_FILE          (5)
#define KIND_FILESYSTEM    (0x14a6b1)

static const uint8_t *rom_image;      // start of the image (its header)
static const uint8_t *rom_image_end;
static const uint8_t *rom_root;       // the root directory's records
static const uint8_t *rom_root_end;

// Decodes one uint at *p (not beyond end); false if it runs off the end.
static bool get_uint(const uint8_t **p, const uint8_t *end, uint32_t *out) {
    uint32_t v = 0;
    const uint8_t *q = *p;
    for (int n = 0; n < 5; n++) {
        if (q >= end) {
            return false;
        }
        uint8_t b = *q++;
        v = (v << 7) | (b & 0x7f);
        if (!(b & 0x80)) {
            *p = q;
            *out = v;
            return true;
        }
    }
    return false;
}

// One record at *p: its kind and payload; *p moves past it.
static bool get_record(const uint8_t **p, const uint8_t *end, uint32_t *kind,
    const uint8_t **payload, const uint8_t **payload_end) {
    const uint8_t *q = *p;
    uint32_t len;
    if (!get_uint(&q, end, kind) || !get_uint(&q, end, &len) || len > (uint32_t)(end - q)) {
        return false;
    }
    *payload = q;
    *payload_end = q + len;
    *p = q + len;
    return true;
}

int romfs_mount(uintptr_t addr, size_t partition_bytes) {
    const uint8_t *img = (const uint8_t *)addr;
    const uint8_t *p = img;
    uint32_t kind;
    const uint8_t *root, *root_end;
    rom_image = NULL;
    if (!get_record(&p, img + partition_bytes, &kind, &root, &root_end) || kind != KIND_FILESYSTEM) {
        // No image (erased or zeroed flash), or one larger than the partition.
        return (img[0] == 0xd2 && img[1] == 0xcd && img[2] == 0x31) ? -1 : 0;
    }
    rom_image = img;
    rom_image_end = p;
    rom_root = root;
    rom_root_end = root_end;
    return 1;
}

bool romfs_mounted(void) {
    return rom_image != NULL;
}

size_t romfs_image_bytes(void) {
    return rom_image ? (size_t)(rom_image_end - rom_image) : 0;
}

const char *romfs_rel(const char *path) {
    if (rom_image == NULL || strncmp(path, ROMFS_MOUNT, sizeof(ROMFS_MOUNT) - 1) != 0) {
        return NULL;
    }
    const char *rest = path + sizeof(ROMFS_MOUNT) - 1;
    if (*rest != '\0' && *rest != '/') {
        return NULL;  // "/romx"
    }
    return rest;
}

// An entry's name: the payload's leading  uint(length) name.
static bool get_name(const uint8_t **p, const uint8_t *end, const uint8_t **name, uint32_t *len) {
    if (!get_uint(p, end, len) || *len > (uint32_t)(end - *p)) {
        return false;
    }
    *name = *p;
    *p += *len;
    return true;
}

// The data of a file record whose name has been read (p .. end).
static bool file_data(const uint8_t *p, const uint8_t *end, romfs_entry_t *e) {
    while (p < end) {
        uint32_t kind;
        const uint8_t *d, *d_end;
        if (!get_record(&p, end, &kind, &d, &d_end)) {
            return false;
        }
        if (kind == KIND_DATA_VERBATIM) {
            e->data = d;
            e->len = d_end - d;
            return true;
        }
        if (kind == KIND_DATA_POINTER) {
            uint32_t len, off;
            if (!get_uint(&d, d_end, &len) || !get_uint(&d, d_end, &off)
                || off > (uint32_t)(rom_image_end - rom_image) || len > (uint32_t)(rom_image_end - rom_image) - off) {
                return false;
            }
            e->data = rom_image + off;
            e->len = len;
            return true;
        }
    }
    e->data = p;  // a file with no data record: empty
    e->len = 0;
    return true;
}

int romfs_lookup(const char *rel, romfs_entry_t *e) {
    const uint8_t *dir = rom_root, *dir_end = rom_root_end;
    e->kind = ROMFS_DIR;
    e->data = dir;
    e->len = dir_end - dir;
    for (;;) {
        while (*rel == '/') {
            rel++;
        }
        if (*rel == '\0') {
            return e->kind;
        }
        const char *c_end = rel;
        while (*c_end && *c_end != '/') {
            c_end++;
        }
        size_t c_len = c_end - rel;
        if (e->kind != ROMFS_DIR) {
            return ROMFS_MISSING;  // "file/more"
        }
        if (c_len == 1 && rel[0] == '.') {
            rel = c_end;
            continue;
        }
        const uint8_t *p = dir;
        bool found = false;
        while (p < dir_end) {
            uint32_t kind, n_len;
            const uint8_t *pl, *pl_end, *name;
            if (!get_record(&p, dir_end, &kind, &pl, &pl_end)) {
                return ROMFS_MISSING;
            }
            if (kind != KIND_DIRECTORY && kind != KIND_FILE) {
                continue;
            }
            if (!get_name(&pl, pl_end, &name, &n_len)) {
                return ROMFS_MISSING;
            }
            if (n_len != c_len || memcmp(name, rel, c_len) != 0) {
                continue;
            }
            if (kind == KIND_DIRECTORY) {
                e->kind = ROMFS_DIR;
                e->data = dir = pl;
                e->len = (dir_end = pl_end) - pl;
            } else {
                e->kind = ROMFS_FILE;
                if (!file_data(pl, pl_end, e)) {
                    return ROMFS_MISSING;
                }
            }
            found = true;
            break;
        }
        if (!found) {
            return ROMFS_MISSING;
        }
        rel = c_end;
    }
}

bool romfs_dir_next(const uint8_t **p, const uint8_t *end, romfs_entry_t *e, const char **name, size_t *name_len) {
    while (*p < end) {
        uint32_t kind, n_len;
        const uint8_t *pl, *pl_end, *n;
        if (!get_record(p, end, &kind, &pl, &pl_end)) {
            return false;
        }
        if (kind != KIND_DIRECTORY && kind != KIND_FILE) {
            continue;
        }
        if (!get_name(&pl, pl_end, &n, &n_len)) {
            return false;
        }
        *name = (const char *)n;
        *name_len = n_len;
        if (kind == KIND_DIRECTORY) {
            e->kind = ROMFS_DIR;
            e->data = pl;
            e->len = pl_end - pl;
        } else {
            e->kind = ROMFS_FILE;
            if (!file_data(pl, pl_end, e)) {
                return false;
            }
        }
        return true;
    }
    return false;
}
