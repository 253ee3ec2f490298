// Host files over semihosting: open(), the file objects, imports, `os`.
//
// Semihosting cannot tell a directory from a file: QEMU's host open() of a
// directory read-only succeeds. We ask the host to open "PATH/.", which
// succeeds for a directory and fails (ENOTDIR) for a file.
#include <string.h>

#include "genhdr/mpversion.h"
#include "py/builtin.h"
#include "py/lexer.h"
#include "py/mperrno.h"
#include "py/objstr.h"
#include "py/objtuple.h"
#include "py/reader.h"
#include "py/runtime.h"
#include "py/stream.h"
#include "semihost.h"
#include "hostfile.h"
#include "romfs.h"

typedef struct _hostfile_obj_t {
    mp_obj_base_t base;
    int handle;     // -1 once closed
    uint32_t pos;   // semihosting has no tell: kept here
} hostfile_obj_t;

static MP_NORETURN void raise_host_errno(void) {
    int e = sh_errno();
    mp_raise_OSError(e > 0 ? e : MP_EIO);
}

static int open_path(const char *path, int mode) {
    return sh_open(path, strlen(path), mode);
}

// 0: missing, 1: file, 2: directory.
static int host_kind(const char *path, int *err) {
    int h = open_path(path, SH_MODE_R);
    if (h < 0) {
        *err = sh_errno();
        return 0;
    }
    sh_close(h);
    size_t len = strlen(path);
    char *buf = alloca(len + 3);
    memcpy(buf, path, len);
    memcpy(buf + len, "/.", 3);
    h = sh_open(buf, len + 2, SH_MODE_R);
    if (h >= 0) {
        sh_close(h);
        return 2;
    }
    return 1;
}

static mp_uint_t hostfile_read(mp_obj_t self_in, void *buf, mp_uint_t size, int *errcode) {
    hostfile_obj_t *self = MP_OBJ_TO_PTR(self_in);
    if (self->handle < 0) {
        *errcode = MP_EBADF;
        return MP_STREAM_ERROR;
    }
    // A file's read(n) gives n bytes unless at EOF: a pipe hands data over in
    // parts, so read until n or end of file.
    mp_uint_t got = 0;
    while (got < size) {
        int n = sh_read_some(self->handle, (char *)buf + got, size - got);
        if (n < 0) {
            if (got) {
                break;
            }
            *errcode = sh_errno();
            return MP_STREAM_ERROR;
        }
        if (n == 0) {
            break;
        }
        got += n;
    }
    self->pos += got;
    return got;
}

static mp_uint_t hostfile_write(mp_obj_t self_in, const void *buf, mp_uint_t size, int *errcode) {
    hostfile_obj_t *self = MP_OBJ_TO_PTR(self_in);
    if (self->handle < 0) {
        *errcode = MP_EBADF;
        return MP_STREAM_ERROR;
    }
    size_t n = sh_write(self->handle, buf, size);
    if (n == 0 && size != 0) {
        *errcode = sh_errno();
        return MP_STREAM_ERROR;
    }
    self->pos += n;
    return n;
}

static mp_uint_t hostfile_ioctl(mp_obj_t self_in, mp_uint_t request, uintptr_t arg, int *errcode) {
    hostfile_obj_t *self = MP_OBJ_TO_PTR(self_in);
    if (request == MP_STREAM_CLOSE) {
        if (self->handle >= 0) {
            sh_close(self->handle);
            self->handle = -1;
        }
        return 0;
    }
    if (self->handle < 0) {
        *errcode = MP_EBADF;
        return MP_STREAM_ERROR;
    }
    switch (request) {
        case MP_STREAM_FLUSH:
            return 0;  // writes go straight to the host
        case MP_STREAM_SEEK: {
            struct mp_stream_seek_t *s = (struct mp_stream_seek_t *)arg;
            mp_int_t base = 0;
            if (s->whence == 1) {
                base = self->pos;
            } else if (s->whence == 2) {
                int len = sh_flen(self->handle);
                if (len < 0) {
                    *errcode = MP_ESPIPE;
                    return MP_STREAM_ERROR;
                }
                base = len;
            }
            mp_int_t target = base + s->offset;
            if (target < 0) {
                *errcode = MP_EINVAL;
                return MP_STREAM_ERROR;
            }
            if (sh_seek(self->handle, (uint32_t)target) != 0) {
                *errcode = MP_ESPIPE;
                return MP_STREAM_ERROR;
            }
            self->pos = (uint32_t)target;
            s->offset = target;
            return 0;
        }
        default:
            *errcode = MP_EINVAL;
            return MP_STREAM_ERROR;
    }
}

static void hostfile_print(const mp_print_t *print, mp_obj_t self_in, mp_print_kind_t kind) {
    (void)kind;
    hostfile_obj_t *self = MP_OBJ_TO_PTR(self_in);
    mp_printf(print, "<io.%s %d>", mp_obj_get_type_str(self_in), self->handle);
}

static mp_obj_t hostfile___exit__(size_t n_args, const mp_obj_t *args) {
    (void)n_args;
    return mp_stream_close(args[0]);
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(hostfile___exit___obj, 4, 4, hostfile___exit__);

static const mp_rom_map_elem_t hostfile_locals_dict_table[] = {
    { MP_ROM_QSTR(MP_QSTR_read), MP_ROM_PTR(&mp_stream_read_obj) },
    { MP_ROM_QSTR(MP_QSTR_readinto), MP_ROM_PTR(&mp_stream_readinto_obj) },
    { MP_ROM_QSTR(MP_QSTR_readline), MP_ROM_PTR(&mp_stream_unbuffered_readline_obj) },
    { MP_ROM_QSTR(MP_QSTR_readlines), MP_ROM_PTR(&mp_stream_unbuffered_readlines_obj) },
    { MP_ROM_QSTR(MP_QSTR_write), MP_ROM_PTR(&mp_stream_write_obj) },
    { MP_ROM_QSTR(MP_QSTR_flush), MP_ROM_PTR(&mp_stream_flush_obj) },
    { MP_ROM_QSTR(MP_QSTR_seek), MP_ROM_PTR(&mp_stream_seek_obj) },
    { MP_ROM_QSTR(MP_QSTR_tell), MP_ROM_PTR(&mp_stream_tell_obj) },
    { MP_ROM_QSTR(MP_QSTR_close), MP_ROM_PTR(&mp_stream_close_obj) },
    { MP_ROM_QSTR(MP_QSTR___del__), MP_ROM_PTR(&mp_stream_close_obj) },
    { MP_ROM_QSTR(MP_QSTR___enter__), MP_ROM_PTR(&mp_identity_obj) },
    { MP_ROM_QSTR(MP_QSTR___exit__), MP_ROM_PTR(&hostfile___exit___obj) },
};
static MP_DEFINE_CONST_DICT(hostfile_locals_dict, hostfile_locals_dict_table);

static const mp_stream_p_t hostfile_fileio_stream_p = {
    .read = hostfile_read,
    .write = hostfile_write,
    .ioctl = hostfile_ioctl,
};

static const mp_stream_p_t hostfile_textio_stream_p = {
    .read = hostfile_read,
    .write = hostfile_write,
    .ioctl = hostfile_ioctl,
    .is_text = true,
};

static MP_DEFINE_CONST_OBJ_TYPE(
    hostfile_type_fileio,
    MP_QSTR_FileIO,
    MP_TYPE_FLAG_ITER_IS_STREAM,
    print, hostfile_print,
    protocol, &hostfile_fileio_stream_p,
    locals_dict, &hostfile_locals_dict
    );

static MP_DEFINE_CONST_OBJ_TYPE(
    hostfile_type_textio,
    MP_QSTR_TextIOWrapper,
    MP_TYPE_FLAG_ITER_IS_STREAM,
    print, hostfile_print,
    protocol, &hostfile_textio_stream_p,
    locals_dict, &hostfile_locals_dict
    );

// ---------------------------------------------------------------- /rom files
// Read-only views of a file in the ROMFS image: reads copy from the mapped
// image, nothing is loaded into the heap.
typedef struct _romfile_obj_t {
    mp_obj_base_t base;
    const uint8_t *data;   // NULL once closed
    uint32_t len;
    uint32_t pos;
} romfile_obj_t;

static mp_uint_t romfile_read(mp_obj_t self_in, void *buf, mp_uint_t size, int *errcode) {
    romfile_obj_t *self = MP_OBJ_TO_PTR(self_in);
    if (self->data == NULL) {
        *errcode = MP_EBADF;
        return MP_STREAM_ERROR;
    }
    mp_uint_t n = self->pos < self->len ? self->len - self->pos : 0;
    if (n > size) {
        n = size;
    }
    memcpy(buf, self->data + self->pos, n);
    self->pos += n;
    return n;
}

static mp_uint_t romfile_write(mp_obj_t self_in, const void *buf, mp_uint_t size, int *errcode) {
    (void)self_in;
    (void)buf;
    (void)size;
    *errcode = MP_EBADF;   // opened for reading only
    return MP_STREAM_ERROR;
}

static mp_uint_t romfile_ioctl(mp_obj_t self_in, mp_uint_t request, uintptr_t arg, int *errcode) {
    romfile_obj_t *self = MP_OBJ_TO_PTR(self_in);
    if (request == MP_STREAM_CLOSE) {
        self->data = NULL;
        return 0;
    }
    if (self->data == NULL) {
        *errcode = MP_EBADF;
        return MP_STREAM_ERROR;
    }
    switch (request) {
        case MP_STREAM_FLUSH:
            return 0;
        case MP_STREAM_SEEK: {
            struct mp_stream_seek_t *s = (struct mp_stream_seek_t *)arg;
            mp_int_t base = s->whence == 1 ? (mp_int_t)self->pos : s->whence == 2 ? (mp_int_t)self->len : 0;
            mp_int_t target = base + s->offset;
            if (target < 0) {
                *errcode = MP_EINVAL;
                return MP_STREAM_ERROR;
            }
            self->pos = (uint32_t)target;
            s->offset = target;
            return 0;
        }
        default:
            *errcode = MP_EINVAL;
            return MP_STREAM_ERROR;
    }
}

static void romfile_print(const mp_print_t *print, mp_obj_t self_in, mp_print_kind_t kind) {
    (void)kind;
    mp_printf(print, "<io.%s /rom>", mp_obj_get_type_str(self_in));
}

static const mp_stream_p_t romfile_fileio_stream_p = {
    .read = romfile_read,
    .write = romfile_write,
    .ioctl = romfile_ioctl,
};

static const mp_stream_p_t romfile_textio_stream_p = {
    .read = romfile_read,
    .write = romfile_write,
    .ioctl = romfile_ioctl,
    .is_text = true,
};

static MP_DEFINE_CONST_OBJ_TYPE(
    romfile_type_fileio,
    MP_QSTR_FileIO,
    MP_TYPE_FLAG_ITER_IS_STREAM,
    print, romfile_print,
    protocol, &romfile_fileio_stream_p,
    locals_dict, &hostfile_locals_dict
    );

static MP_DEFINE_CONST_OBJ_TYPE(
    romfile_type_textio,
    MP_QSTR_TextIOWrapper,
    MP_TYPE_FLAG_ITER_IS_STREAM,
    print, romfile_print,
    protocol, &romfile_textio_stream_p,
    locals_dict, &hostfile_locals_dict
    );

static mp_obj_t romfile_open(const char *rel, int mode, bool binary) {
    if (mode != SH_MODE_R) {
        mp_raise_OSError(MP_EROFS);
    }
    romfs_entry_t e;
    switch (romfs_lookup(rel, &e)) {
        case ROMFS_FILE:
            break;
        case ROMFS_DIR:
            mp_raise_OSError(MP_EISDIR);
        default:
            mp_raise_OSError(MP_ENOENT);
    }
    romfile_obj_t *o = mp_obj_malloc(romfile_obj_t, binary ? &romfile_type_fileio : &romfile_type_textio);
    o->data = e.data;
    o->len = e.len;
    o->pos = 0;
    return MP_OBJ_FROM_PTR(o);
}

mp_obj_t mp_builtin_open(size_t n_args, const mp_obj_t *args, mp_map_t *kwargs) {
    enum { ARG_file, ARG_mode, ARG_buffering, ARG_encoding };
    static const mp_arg_t allowed[] = {
        { MP_QSTR_file, MP_ARG_OBJ | MP_ARG_REQUIRED, {.u_rom_obj = MP_ROM_NONE} },
        { MP_QSTR_mode, MP_ARG_OBJ, {.u_rom_obj = MP_ROM_QSTR(MP_QSTR_r)} },
        { MP_QSTR_buffering, MP_ARG_INT, {.u_int = -1} },
        { MP_QSTR_encoding, MP_ARG_OBJ, {.u_rom_obj = MP_ROM_NONE} },
    };
    mp_arg_val_t a[MP_ARRAY_SIZE(allowed)];
    mp_arg_parse_all(n_args, args, kwargs, MP_ARRAY_SIZE(allowed), allowed, a);
    const char *path = mp_obj_str_get_str(a[ARG_file].u_obj);
    const char *mode_s = mp_obj_str_get_str(a[ARG_mode].u_obj);

    int mode = -1;
    bool binary = false, plus = false;
    for (const char *m = mode_s; *m; m++) {
        switch (*m) {
            case 'r':
                mode = SH_MODE_R;
                break;
            case 'w':
                mode = SH_MODE_W;
                break;
            case 'a':
                mode = SH_MODE_A;
                break;
            case '+':
                plus = true;
                break;
            case 'b':
                binary = true;
                break;
            case 't':
                binary = false;
                break;
            default:
                mp_raise_ValueError(MP_ERROR_TEXT("invalid mode"));
        }
    }
    if (mode < 0) {
        mp_raise_ValueError(MP_ERROR_TEXT("invalid mode"));
    }
    if (plus) {
        mode += 2;
    }
    const char *rel = romfs_rel(path);
    if (rel != NULL) {
        return romfile_open(rel, mode, binary);
    }
    if (binary) {
        mode += 1;
    }
    int h = open_path(path, mode);
    if (h < 0) {
        raise_host_errno();
    }
    if (mode == SH_MODE_R || mode == SH_MODE_R + 1 || mode == SH_MODE_RP || mode == SH_MODE_RP + 1) {
        // Reading a directory fails on the host only at read(): refuse it here.
        int err;
        if (host_kind(path, &err) == 2) {
            sh_close(h);
            mp_raise_OSError(MP_EISDIR);
        }
    }
    hostfile_obj_t *o = mp_obj_malloc_with_finaliser(hostfile_obj_t, binary ? &hostfile_type_fileio : &hostfile_type_textio);
    o->handle = h;
    o->pos = 0;
    if (mode >= SH_MODE_A) {
        // QEMU 7.2 opens "a" without O_APPEND: start writing at the end.
        int len = sh_flen(h);
        if (len > 0 && sh_seek(h, (uint32_t)len) == 0) {
            o->pos = (uint32_t)len;
        }
    }
    return MP_OBJ_FROM_PTR(o);
}
MP_DEFINE_CONST_FUN_OBJ_KW(mp_builtin_open_obj, 1, mp_builtin_open);

// ---------------------------------------------------------------- imports
mp_import_stat_t mp_import_stat(const char *path) {
    const char *rel = romfs_rel(path);
    if (rel != NULL) {
        romfs_entry_t e;
        switch (romfs_lookup(rel, &e)) {
            case ROMFS_DIR:
                return MP_IMPORT_STAT_DIR;
            case ROMFS_FILE:
                return MP_IMPORT_STAT_FILE;
            default:
                return MP_IMPORT_STAT_NO_EXIST;
        }
    }
    int err;
    switch (host_kind(path, &err)) {
        case 2:
            return MP_IMPORT_STAT_DIR;
        case 1:
            return MP_IMPORT_STAT_FILE;
        default:
            return MP_IMPORT_STAT_NO_EXIST;
    }
}

void mp_reader_new_file(mp_reader_t *reader, qstr filename) {
    const char *path = qstr_str(filename);
    const char *rel = romfs_rel(path);
    if (rel != NULL) {
        // Read in place: flagged as ROM, the .mpy loader references the
        // image's bytecode and strings instead of copying them to the heap.
        romfs_entry_t e;
        int kind = romfs_lookup(rel, &e);
        if (kind != ROMFS_FILE) {
            mp_raise_OSError(kind == ROMFS_DIR ? MP_EISDIR : MP_ENOENT);
        }
        mp_reader_new_mem(reader, e.data, e.len, MP_READER_IS_ROM);
        return;
    }
    int h = open_path(path, SH_MODE_R + 1);
    if (h < 0) {
        raise_host_errno();
    }
    int len = sh_flen(h);
    if (len < 0) {
        sh_close(h);
        mp_raise_OSError(MP_EIO);
    }
    byte *buf = m_new(byte, len ? len : 1);
    size_t got = 0;
    while (got < (size_t)len) {
        int n = sh_read_some(h, buf + got, len - got);
        if (n <= 0) {
            break;
        }
        got += n;
    }
    sh_close(h);
    mp_reader_new_mem(reader, buf, got, len ? len : 1);
}

mp_lexer_t *mp_lexer_new_from_file(qstr filename) {
    mp_reader_t reader;
    mp_reader_new_file(&reader, filename);
    return mp_lexer_new(filename, reader);
}

// ---------------------------------------------------------------- os
static mp_obj_t os_stat(mp_obj_t path_in) {
    const char *path = mp_obj_str_get_str(path_in);
    int err = 0;
    mp_int_t size = 0;
    int kind;
    const char *rel = romfs_rel(path);
    if (rel != NULL) {
        romfs_entry_t e;
        kind = romfs_lookup(rel, &e);
        if (kind == ROMFS_MISSING) {
            mp_raise_OSError(MP_ENOENT);
        }
        if (kind == ROMFS_FILE) {
            size = e.len;
        }
    } else {
        kind = host_kind(path, &err);
    }
    if (kind == 0) {
        mp_raise_OSError(err > 0 ? err : MP_ENOENT);
    }
    if (kind == 1 && rel == NULL) {
        int h = open_path(path, SH_MODE_R + 1);
        if (h >= 0) {
            int len = sh_flen(h);
            size = len > 0 ? len : 0;
            sh_close(h);
        }
    }
    mp_obj_tuple_t *t = MP_OBJ_TO_PTR(mp_obj_new_tuple(10, NULL));
    t->items[0] = MP_OBJ_NEW_SMALL_INT(kind == 2 ? 0x4000 : 0x8000);
    for (int i = 1; i < 10; i++) {
        t->items[i] = MP_OBJ_NEW_SMALL_INT(0);
    }
    t->items[6] = mp_obj_new_int(size);
    return MP_OBJ_FROM_PTR(t);
}
static MP_DEFINE_CONST_FUN_OBJ_1(os_stat_obj, os_stat);

static mp_obj_t os_remove(mp_obj_t path_in) {
    size_t len;
    const char *path = mp_obj_str_get_data(path_in, &len);
    if (romfs_rel(path) != NULL) {
        mp_raise_OSError(MP_EROFS);
    }
    if (sh_remove(path, len) != 0) {
        raise_host_errno();
    }
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_1(os_remove_obj, os_remove);

static mp_obj_t os_rename(mp_obj_t from_in, mp_obj_t to_in) {
    size_t from_len, to_len;
    const char *from = mp_obj_str_get_data(from_in, &from_len);
    const char *to = mp_obj_str_get_data(to_in, &to_len);
    if (romfs_rel(from) != NULL || romfs_rel(to) != NULL) {
        mp_raise_OSError(MP_EROFS);
    }
    if (sh_rename(from, from_len, to, to_len) != 0) {
        raise_host_errno();
    }
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_2(os_rename_obj, os_rename);

static mp_obj_t os_unsupported(size_t n_args, const mp_obj_t *args) {
    (void)n_args;
    (void)args;
    mp_raise_OSError(38);  // ENOSYS: semihosting has no directories
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(os_unsupported_obj, 0, 2, os_unsupported);

// Host folders. Semihosting has no directory calls; its SYS_SYSTEM runs a
// command in the host's shell (QEMU: system(3), in QEMU's working
// directory, the board's root), which makes a folder and lists one into a
// file the board then reads. The flight log keeps its files in /logs
// (firmware/flightlog/files.py). Paths are single-quoted: one holding a
// quote is refused.
#define LISTING ".rp2350-emu-listdir"

static void host_command(vstr_t *cmd, const char *head, const char *path, const char *tail) {
    if (strchr(path, '\'') != NULL || path[0] == '\0') {
        mp_raise_OSError(MP_EINVAL);
    }
    vstr_init(cmd, 64);
    vstr_add_str(cmd, head);
    vstr_add_str(cmd, " -- '");
    vstr_add_str(cmd, path);
    vstr_add_str(cmd, "'");
    vstr_add_str(cmd, tail);
    vstr_null_terminated_str(cmd);   // (SYS_SYSTEM reads the length and a NUL after it)
}

static mp_obj_t os_mkdir(mp_obj_t path_in) {
    const char *path = mp_obj_str_get_str(path_in);
    if (romfs_rel(path) != NULL) {
        mp_raise_OSError(MP_EROFS);
    }
    int err = 0;
    if (host_kind(path, &err) != 0) {
        mp_raise_OSError(MP_EEXIST);
    }
    vstr_t cmd;
    host_command(&cmd, "mkdir", path, " 2>/dev/null");
    int status = sh_system(cmd.buf, cmd.len);
    vstr_clear(&cmd);
    if (status != 0) {
        mp_raise_OSError(MP_EIO);
    }
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_1(os_mkdir_obj, os_mkdir);

static mp_obj_t host_listdir(const char *path) {
    int err = 0;
    int kind = host_kind(path, &err);
    if (kind != 2) {
        mp_raise_OSError(kind == 1 ? MP_ENOTDIR : MP_ENOENT);
    }
    vstr_t cmd;
    host_command(&cmd, "ls -1A", path, " > " LISTING " 2>/dev/null");
    int status = sh_system(cmd.buf, cmd.len);
    vstr_clear(&cmd);
    int h = sh_open(LISTING, strlen(LISTING), SH_MODE_R + 1);
    if (status != 0 || h < 0) {
        if (h >= 0) {
            sh_close(h);
        }
        mp_raise_OSError(MP_EIO);
    }
    int len = sh_flen(h);
    vstr_t text;
    vstr_init_len(&text, len > 0 ? len : 0);
    int got = len > 0 ? sh_read_some(h, text.buf, len) : 0;
    sh_close(h);
    sh_remove(LISTING, strlen(LISTING));
    mp_obj_t list = mp_obj_new_list(0, NULL);
    const char *p = text.buf, *end = text.buf + (got > 0 ? got : 0);
    while (p < end) {
        const char *nl = memchr(p, '\n', end - p);
        const char *stop = nl != NULL ? nl : end;
        // (the listing's own file, when the board lists its root)
        if (stop > p && !((size_t)(stop - p) == strlen(LISTING) && memcmp(p, LISTING, stop - p) == 0)) {
            mp_obj_list_append(list, mp_obj_new_str(p, stop - p));
        }
        p = stop + 1;
    }
    vstr_clear(&text);
    return list;
}

// statvfs of the board's flash: a Pico 2's file system (littlefs, 4 kB
// blocks, 3 MB: MICROPY_HW_FLASH_STORAGE_BYTES of the rp2 port's
// RPI_PICO2), reported all free, since the host's folder is not a flash
// that fills.
static mp_obj_t os_statvfs(mp_obj_t path_in) {
    (void)path_in;
    mp_obj_tuple_t *t = MP_OBJ_TO_PTR(mp_obj_new_tuple(10, NULL));
    static const mp_int_t v[10] = {4096, 4096, 768, 768, 768, 0, 0, 0, 0, 255};
    for (int i = 0; i < 10; i++) {
        t->items[i] = MP_OBJ_NEW_SMALL_INT(v[i]);
    }
    return MP_OBJ_FROM_PTR(t);
}
static MP_DEFINE_CONST_FUN_OBJ_1(os_statvfs_obj, os_statvfs);

// listdir: the ROMFS image, or a host folder.
static mp_obj_t os_listdir(size_t n_args, const mp_obj_t *args) {
    const char *path = n_args ? mp_obj_str_get_str(args[0]) : "";
    const char *rel = romfs_rel(path);
    if (rel == NULL) {
        // the board's root is QEMU's working directory
        return host_listdir(path[0] && strcmp(path, "/") != 0 ? path : ".");
    }
    romfs_entry_t e;
    int kind = romfs_lookup(rel, &e);
    if (kind != ROMFS_DIR) {
        mp_raise_OSError(kind == ROMFS_FILE ? MP_ENOTDIR : MP_ENOENT);
    }
    mp_obj_t list = mp_obj_new_list(0, NULL);
    const uint8_t *p = e.data, *end = e.data + e.len;
    romfs_entry_t child;
    const char *name;
    size_t name_len;
    while (romfs_dir_next(&p, end, &child, &name, &name_len)) {
        mp_obj_list_append(list, mp_obj_new_str(name, name_len));
    }
    return list;
}
static MP_DEFINE_CONST_FUN_OBJ_VAR_BETWEEN(os_listdir_obj, 0, 1, os_listdir);

static mp_obj_t os_getcwd(void) {
    return MP_OBJ_NEW_QSTR(MP_QSTR_);
}
static MP_DEFINE_CONST_FUN_OBJ_0(os_getcwd_obj, os_getcwd);

static mp_obj_t os_sync(void) {
    return mp_const_none;
}
static MP_DEFINE_CONST_FUN_OBJ_0(os_sync_obj, os_sync);

static const qstr os_uname_fields[] = {
    MP_QSTR_sysname, MP_QSTR_nodename, MP_QSTR_release, MP_QSTR_version, MP_QSTR_machine
};
static const MP_DEFINE_STR_OBJ(os_uname_sysname_obj, "rp2");
static const MP_DEFINE_STR_OBJ(os_uname_release_obj, MICROPY_VERSION_STRING);
static const MP_DEFINE_STR_OBJ(os_uname_version_obj, MICROPY_GIT_TAG " on " MICROPY_BUILD_DATE);
static const MP_DEFINE_STR_OBJ(os_uname_machine_obj, MICROPY_HW_BOARD_NAME " with " MICROPY_HW_MCU_NAME);
static MP_DEFINE_ATTRTUPLE(
    os_uname_info_obj,
    os_uname_fields,
    5,
    MP_ROM_PTR(&os_uname_sysname_obj),
    MP_ROM_PTR(&os_uname_sysname_obj),
    MP_ROM_PTR(&os_uname_release_obj),
    MP_ROM_PTR(&os_uname_version_obj),
    MP_ROM_PTR(&os_uname_machine_obj)
    );

static mp_obj_t os_uname(void) {
    return MP_OBJ_FROM_PTR(&os_uname_info_obj);
}
static MP_DEFINE_CONST_FUN_OBJ_0(os_uname_obj, os_uname);

// Deterministic: the same bytes every run (xorshift32 from a fixed seed).
static uint32_t urandom_state = 0x2545f491;
static mp_obj_t os_urandom(mp_obj_t n_in) {
    mp_int_t n = mp_obj_get_int(n_in);
    vstr_t vstr;
    vstr_init_len(&vstr, n);
    for (mp_int_t i = 0; i < n; i++) {
        uint32_t x = urandom_state;
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        urandom_state = x;
        vstr.buf[i] = (char)x;
    }
    return mp_obj_new_bytes_from_vstr(&vstr);
}
static MP_DEFINE_CONST_FUN_OBJ_1(os_urandom_obj, os_urandom);

static const mp_rom_map_elem_t os_globals_table[] = {
    { MP_ROM_QSTR(MP_QSTR___name__), MP_ROM_QSTR(MP_QSTR_os) },
    { MP_ROM_QSTR(MP_QSTR_stat), MP_ROM_PTR(&os_stat_obj) },
    { MP_ROM_QSTR(MP_QSTR_remove), MP_ROM_PTR(&os_remove_obj) },
    { MP_ROM_QSTR(MP_QSTR_unlink), MP_ROM_PTR(&os_remove_obj) },
    { MP_ROM_QSTR(MP_QSTR_rename), MP_ROM_PTR(&os_rename_obj) },
    { MP_ROM_QSTR(MP_QSTR_listdir), MP_ROM_PTR(&os_listdir_obj) },
    { MP_ROM_QSTR(MP_QSTR_ilistdir), MP_ROM_PTR(&os_unsupported_obj) },
    { MP_ROM_QSTR(MP_QSTR_mkdir), MP_ROM_PTR(&os_mkdir_obj) },
    { MP_ROM_QSTR(MP_QSTR_rmdir), MP_ROM_PTR(&os_unsupported_obj) },
    { MP_ROM_QSTR(MP_QSTR_chdir), MP_ROM_PTR(&os_unsupported_obj) },
    { MP_ROM_QSTR(MP_QSTR_statvfs), MP_ROM_PTR(&os_statvfs_obj) },
    { MP_ROM_QSTR(MP_QSTR_getcwd), MP_ROM_PTR(&os_getcwd_obj) },
    { MP_ROM_QSTR(MP_QSTR_sync), MP_ROM_PTR(&os_sync_obj) },
    { MP_ROM_QSTR(MP_QSTR_uname), MP_ROM_PTR(&os_uname_obj) },
    { MP_ROM_QSTR(MP_QSTR_urandom), MP_ROM_PTR(&os_urandom_obj) },
    { MP_ROM_QSTR(MP_QSTR_sep), MP_ROM_QSTR(MP_QSTR__slash_) },
};
static MP_DEFINE_CONST_DICT(os_globals, os_globals_table);

const mp_obj_module_t os_module = {
    .base = { &mp_type_module },
    .globals = (mp_obj_dict_t *)&os_globals,
};
MP_REGISTER_MODULE(MP_QSTR_os, os_module);
