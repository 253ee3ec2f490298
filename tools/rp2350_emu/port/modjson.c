// `json`: dumps() through the core's JSON printing, loads() parsed here.
#include <math.h>
#include <string.h>

#include "py/objstr.h"
#include "py/parsenum.h"
#include "py/runtime.h"

static mp_obj_t json_dumps(mp_obj_t obj) {
    vstr_t vstr;
    mp_print_t print;
    vstr_init_print(&vstr, 16, &print);
    mp_obj_print_helper(&print, obj, PRINT_JSON);
    return mp_obj_new_str_from_utf8_vstr(&vstr);
}
static MP_DEFINE_CONST_FUN_OBJ_1(json_dumps_obj, json_dumps);

typedef struct {
    const char *p;
    const char *end;
} json_in_t;

static MP_NORETURN void json_error(void) {
    mp_raise_ValueError(MP_ERROR_TEXT("syntax error in JSON"));
}

static void skip_ws(json_in_t *in) {
    while (in->p < in->end && (*in->p == ' ' || *in->p == '\t' || *in->p == '\n' || *in->p == '\r')) {
        in->p++;
    }
}

static bool take(json_in_t *in, const char *word) {
    size_t n = strlen(word);
    if ((size_t)(in->end - in->p) >= n && memcmp(in->p, word, n) == 0) {
        in->p += n;
        return true;
    }
    return false;
}

static int hex4(json_in_t *in) {
    if (in->end - in->p < 4) {
        json_error();
    }
    int v = 0;
    for (int i = 0; i < 4; i++) {
        char c = *in->p++;
        v <<= 4;
        if (c >= '0' && c <= '9') {
            v |= c - '0';
        } else if ((c | 0x20) >= 'a' && (c | 0x20) <= 'f') {
            v |= (c | 0x20) - 'a' + 10;
        } else {
            json_error();
        }
    }
    return v;
}

static mp_obj_t parse_string(json_in_t *in) {
    in->p++;  // the opening quote
    vstr_t vstr;
    vstr_init(&vstr, 8);
    for (;;) {
        if (in->p >= in->end) {
            json_error();
        }
        char c = *in->p++;
        if (c == '"') {
            break;
        }
        if (c != '\\') {
            vstr_add_byte(&vstr, c);
            continue;
        }
        if (in->p >= in->end) {
            json_error();
        }
        c = *in->p++;
        switch (c) {
            case '"':
            case '\\':
            case '/':
                vstr_add_byte(&vstr, c);
                break;
            case 'b':
                vstr_add_byte(&vstr, '\b');
                break;
            case 'f':
                vstr_add_byte(&vstr, '\f');
                break;
            case 'n':
                vstr_add_byte(&vstr, '\n');
                break;
            case 'r':
                vstr_add_byte(&vstr, '\r');
                break;
            case 't':
                vstr_add_byte(&vstr, '\t');
                break;
            case 'u': {
                unichar u = hex4(in);
                if (u >= 0xd800 && u < 0xdc00 && take(in, "\\u")) {
                    unichar lo = hex4(in);
                    u = 0x10000 + ((u - 0xd800) << 10) + (lo - 0xdc00);
                }
                vstr_add_char(&vstr, u);
                break;
            }
            default:
                json_error();
        }
    }
    return mp_obj_new_str_from_utf8_vstr(&vstr);
}

static mp_obj_t parse_value(json_in_t *in);

static mp_obj_t parse_number(json_in_t *in) {
    const char *start = in->p;
    bool is_float = false;
    if (in->p < in->end && *in->p == '-') {
        in->p++;
    }
    while (in->p < in->end) {
        char c = *in->p;
        if (c >= '0' && c <= '9') {
            in->p++;
        } else if (c == '.' || c == 'e' || c == 'E' || ((c == '+' || c == '-') && (in->p[-1] | 0x20) == 'e')) {
            is_float = true;
            in->p++;
        } else {
            break;
        }
    }
    size_t len = in->p - start;
    if (len == 0 || (len == 1 && *start == '-')) {
        json_error();
    }
    if (is_float) {
        return mp_parse_num_float(start, len, false, NULL);
    }
    return mp_parse_num_integer(start, len, 10, NULL);
}

static mp_obj_t parse_value(json_in_t *in) {
    skip_ws(in);
    if (in->p >= in->end) {
        json_error();
    }
    char c = *in->p;
    if (c == '"') {
        return parse_string(in);
    }
    if (c == '{') {
        in->p++;
        mp_obj_t d = mp_obj_new_dict(0);
        skip_ws(in);
        if (in->p < in->end && *in->p == '}') {
            in->p++;
            return d;
        }
        for (;;) {
            skip_ws(in);
            if (in->p >= in->end || *in->p != '"') {
                json_error();
            }
            mp_obj_t key = parse_string(in);
            skip_ws(in);
            if (in->p >= in->end || *in->p++ != ':') {
                json_error();
            }
            mp_obj_dict_store(d, key, parse_value(in));
            skip_ws(in);
            if (in->p < in->end && *in->p == ',') {
                in->p++;
                continue;
            }
            if (in->p < in->end && *in->p == '}') {
                in->p++;
                return d;
            }
            json_error();
        }
    }
    if (c == '[') {
        in->p++;
        mp_obj_t l = mp_obj_new_list(0, NULL);
        skip_ws(in);
        if (in->p < in->end && *in->p == ']') {
            in->p++;
            return l;
        }
        for (;;) {
            mp_obj_list_append(l, parse_value(in));
            skip_ws(in);
            if (in->p < in->end && *in->p == ',') {
                in->p++;
                continue;
            }
            if (in->p < in->end && *in->p == ']') {
                in->p++;
                return l;
            }
            json_error();
        }
    }
    if (take(in, "true")) {
        return mp_const_true;
    }
    if (take(in, "false")) {
        return mp_const_false;
    }
    if (take(in, "null")) {
        return mp_const_none;
    }
    if (take(in, "NaN")) {
        return mp_obj_new_float(NAN);
    }
    if (take(in, "Infinity")) {
        return mp_obj_new_float(INFINITY);
    }
    if (take(in, "-Infinity")) {
        return mp_obj_new_float(-INFINITY);
    }
    return parse_number(in);
}

static mp_obj_t json_loads(mp_obj_t s) {
    mp_buffer_info_t b;
    mp_get_buffer_raise(s, &b, MP_BUFFER_READ);
    json_in_t in = { b.buf, (const char *)b.buf + b.len };
    mp_obj_t v = parse_value(&in);
    skip_ws(&in);
    if (in.p != in.end) {
        json_error();
    }
    return v;
}
static MP_DEFINE_CONST_FUN_OBJ_1(json_loads_obj, json_loads);

static const mp_rom_map_elem_t json_globals_table[] = {
    { MP_ROM_QSTR(MP_QSTR___name__), MP_ROM_QSTR(MP_QSTR_json) },
    { MP_ROM_QSTR(MP_QSTR_dumps), MP_ROM_PTR(&json_dumps_obj) },
    { MP_ROM_QSTR(MP_QSTR_loads), MP_ROM_PTR(&json_loads_obj) },
};
static MP_DEFINE_CONST_DICT(json_globals, json_globals_table);

const mp_obj_module_t json_module = {
    .base = { &mp_type_module },
    .globals = (mp_obj_dict_t *)&json_globals,
};
MP_REGISTER_MODULE(MP_QSTR_json, json_module);
