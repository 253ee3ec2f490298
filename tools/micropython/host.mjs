// Host for the MicroPython WebAssembly port under Node.js.
//
// Two modes, chosen by the first argument:
//
//   node host.mjs exec <micropython.mjs> [heap_bytes] [wasm]
//       Line-delimited JSON on stdin/stdout, one request and one reply a line.
//       The Python side (interpreter.py) is the only client. While code runs,
//       MicroPython may call hostlink.request(text); that writes a
//       {"op": "request"} line and blocks until the client answers with a
//       {"op": "reply"} line, which is how the twin steps the dynamics in
//       lockstep with the firmware. A request takes the next reply line
//       whenever it was sent, so the client may answer ahead (the twin
//       sends frame k+1's inputs while the board runs frame k).
//
//   node host.mjs repl <micropython.mjs> <fs_dir> [heap_bytes] [options_json]
//       Raw bytes: stdin is the board's USB serial input, stdout its output.
//       Used behind a pseudo-terminal by the virtual board (virtual_board.py),
//       which mends what is left of the port's quirks on the byte stream.
//       The file system is loaded from fs_dir at start and written back
//       whenever the board waits for input, so it outlives a restart like a
//       board's flash does.
//       options_json:
//         nonblock_fd   (required) stdin's FIFO opened again without
//                       blocking, so a running program can look for input
//                       (see "The serial line's receive side" below);
//         flash_bytes   capacity os.statvfs reports, as a board's flash does;
//         modules       host .py files the board offers like built-in modules
//                       (the twin's machine), outside the synced flash;
//         identity      {platform, machine, build}: what sys.platform,
//                       sys.implementation and os.uname() say (a Pico 2's);
//         bad_writes    [path_prefix, n]: the first n writes to files whose
//                       path starts with path_prefix store their first byte
//                       with its low bit flipped, as a flash that programs a
//                       bit wrong (see "Bad writes" below).
//
// Everything is synchronous on purpose: MicroPython runs on this thread, so
// reading stdin with fs.readSync is the only way to answer a request made
// from inside a running Python program.

import fs from "node:fs";
import path from "node:path";
import { pathToFileURL } from "node:url";

const mode = process.argv[2];
const mpPath = process.argv[3];
const { loadMicroPython } = await import(pathToFileURL(mpPath).href);

// ---------------------------------------------------------------- stdin, sync
const inBuf = Buffer.alloc(65536);
let pending = Buffer.alloc(0);

function readChunk() {
  for (;;) {
    try {
      const n = fs.readSync(0, inBuf, 0, inBuf.length, null);
      return n === 0 ? null : Buffer.from(inBuf.subarray(0, n));
    } catch (e) {
      if (e.code === "EAGAIN") continue; // non-blocking pipe: spin until data
      if (e.code === "EOF") return null;
      throw e;
    }
  }
}

function readLine() {
  for (;;) {
    const nl = pending.indexOf(10);
    if (nl >= 0) {
      const line = pending.subarray(0, nl).toString("utf8");
      pending = pending.subarray(nl + 1);
      return line;
    }
    const chunk = readChunk();
    if (chunk === null) return null;
    pending = Buffer.concat([pending, chunk]);
  }
}

function writeAll(buf) {
  let off = 0;
  while (off < buf.length) {
    try {
      off += fs.writeSync(1, buf, off, buf.length - off);
    } catch (e) {
      if (e.code !== "EAGAIN") throw e;
    }
  }
}

const send = (obj) => writeAll(Buffer.from(JSON.stringify(obj) + "\n", "utf8"));

// ------------------------------------------------------------ exec protocol
async function execMode() {
  const heap = parseInt(process.argv[4] || "8388608", 10);
  // another build of the same port (the settrace one, for counting lines)
  const wasm = process.argv[5] || undefined;
  let out = [];
  const mp = await loadMicroPython({
    heapsize: heap,
    url: wasm,
    linebuffer: false,
    stdout: (b) => { for (const c of b) out.push(c); },
    stderr: (b) => { for (const c of b) out.push(c); },
  });
  // Per exec: requests made, and the time they spent sending and then
  // blocked until the answer was there (us), for the twin's figures.
  let link = { requests: 0, send_us: 0, wait_us: 0 };
  mp.registerJsModule("hostlink", {
    request(text) {
      const t0 = performance.now();
      send({ op: "request", data: String(text) });
      const t1 = performance.now();
      for (;;) {
        const line = readLine();
        if (line === null) process.exit(0);
        const msg = JSON.parse(line);
        if (msg.op === "reply") {
          link.requests += 1;
          link.send_us += (t1 - t0) * 1000;
          link.wait_us += (performance.now() - t1) * 1000;
          return msg.data;
        }
      }
    },
  });
  const takeOut = () => {
    const s = Buffer.from(out).toString("utf8");
    out = [];
    return s;
  };
  mp.runPython("import sys\n__version = '%d.%d.%d' % sys.implementation.version[:3]");
  send({ op: "ready", version: mp.globals.get("__version") });
  for (;;) {
    const line = readLine();
    if (line === null) return;
    const req = JSON.parse(line);
    // an answer sent ahead that the code ended without asking for
    if (req.op === "reply") continue;
    const reply = { op: "done", id: req.id, ok: true };
    try {
      switch (req.op) {
        case "exec": {
          link = { requests: 0, send_us: 0, wait_us: 0 };
          const t0 = performance.now();
          mp.runPython(req.code);
          reply.us = (performance.now() - t0) * 1000;
          reply.hostlink = link;
          break;
        }
        case "write": {
          mp.FS.mkdirTree(path.posix.dirname(req.path));
          mp.FS.writeFile(req.path, Buffer.from(req.b64, "base64"));
          break;
        }
        case "read":
          reply.b64 = Buffer.from(mp.FS.readFile(req.path)).toString("base64");
          break;
        case "global": {
          const v = mp.globals.get(req.name);
          reply.value = v === undefined ? null : v;
          break;
        }
        default:
          throw new Error("unknown op " + req.op);
      }
    } catch (e) {
      reply.ok = false;
      reply.error = e && e.message !== undefined ? String(e.message) : String(e);
      reply.python = e && e.constructor && e.constructor.name === "PythonError";
    }
    reply.out = takeOut();
    send(reply);
  }
}

// --------------------------------------------------------------- REPL mode
//
// The board's flash is the folder FLASH of Emscripten's in-memory file
// system, which MicroPython mounts at "/" (a VfsPosix rooted there): the
// board sees its files at the root as a Pico 2 does, and none of
// Emscripten's own folders (/tmp, /home, /dev, /proc). Built-in modules live
// in BUILTINS, outside it, as a board's frozen modules are outside its flash.
const FLASH = "/flash";
const BUILTINS = "/builtins";

function loadTree(mp, hostDir, mpDir) {
  for (const name of fs.readdirSync(hostDir)) {
    const h = path.join(hostDir, name);
    const m = path.posix.join(mpDir, name);
    if (fs.statSync(h).isDirectory()) {
      mp.FS.mkdirTree(m);
      loadTree(mp, h, m);
    } else {
      mp.FS.writeFile(m, fs.readFileSync(h));
    }
  }
}

// Mirror the MicroPython file system onto fs_dir. A file is written to a
// temporary name and renamed, so killing the virtual board mid-sync leaves
// every host file whole, old or new.
function syncTree(mp, mpDir, hostDir, seen) {
  for (const name of mp.FS.readdir(mpDir)) {
    if (name === "." || name === "..") continue;
    const m = path.posix.join(mpDir, name);
    const h = path.join(hostDir, name);
    const st = mp.FS.stat(m);
    seen.add(h);
    if (mp.FS.isDir(st.mode)) {
      fs.mkdirSync(h, { recursive: true });
      syncTree(mp, m, h, seen);
    } else {
      const data = mp.FS.readFile(m);
      let same = false;
      try { same = Buffer.compare(fs.readFileSync(h), Buffer.from(data)) === 0; } catch (e) { same = false; }
      if (!same) {
        fs.writeFileSync(h + ".~sync", data);
        fs.renameSync(h + ".~sync", h);
      }
    }
  }
}

function pruneTree(hostDir, seen) {
  for (const name of fs.readdirSync(hostDir)) {
    const h = path.join(hostDir, name);
    if (fs.statSync(h).isDirectory()) {
      pruneTree(h, seen);
      if (!seen.has(h)) fs.rmSync(h, { recursive: true, force: true });
    } else if (!seen.has(h)) {
      fs.rmSync(h, { force: true });
    }
  }
}

// A board's statvfs: littlefs with 4 kB blocks, two blocks of superblock,
// two of metadata a folder and at least one a file. An approximation of
// littlefs's real usage (it inlines tiny files), close enough to check
// that a deployment fits.
const BLOCK = 4096;

function usedBlocks(mp, dir) {
  let blocks = 2;
  for (const name of mp.FS.readdir(dir)) {
    if (name === "." || name === "..") continue;
    const p = path.posix.join(dir, name);
    const st = mp.FS.stat(p);
    if (mp.FS.isDir(st.mode)) blocks += usedBlocks(mp, p);
    else blocks += Math.max(1, Math.ceil(st.size / BLOCK));
  }
  return blocks;
}

// The serial line's receive side: what the host sent that neither the REPL
// nor a program has read yet, as a board's USB receive buffer. The REPL
// reads it when idle, waiting on stdin; a running program reads it through
// sys.stdin (mpremote's mount protocol does), and while any program runs
// the clock hook below looks for new bytes, so Ctrl-C reaches it. A program
// looks without waiting: virtual_board.py hands over its FIFO twice, as
// stdin (blocking) and as nonblock_fd. Bytes that arrive while a program
// runs pass the board's USB handler: the interrupt character (Ctrl-C, or
// what micropython.kbd_intr set; none after kbd_intr(-1), as mount's
// protocol asks) schedules a KeyboardInterrupt instead of being stored.
function serialInput(M, nbFd, state, hangUp) {
  const chunk = Buffer.alloc(4096);
  let rx = Buffer.alloc(0);
  const sleeper = new Int32Array(new SharedArrayBuffer(4));
  const input = {
    // A KeyboardInterrupt scheduled that a read has not yet handed over.
    interrupted: false,
    sleepMs: (ms) => Atomics.wait(sleeper, 0, 0, ms),
    available: () => rx.length,
  };
  const arrived = (n) => {
    let data = Buffer.from(chunk.subarray(0, n));
    const ic = state.running ? M._mp_hal_get_interrupt_char() : -1;
    if (ic >= 0 && data.includes(ic)) {
      const kept = [];
      for (const c of data) if (c !== ic) kept.push(c);
      data = Buffer.from(kept);
      M._mp_sched_keyboard_interrupt();
      input.interrupted = true;
    }
    rx = rx.length ? Buffer.concat([rx, data]) : data;
  };
  // Takes in what has arrived, without waiting; false if nothing had.
  input.look = () => {
    let n;
    try {
      n = fs.readSync(nbFd, chunk, 0, chunk.length, null);
    } catch (e) {
      if (e.code === "EAGAIN") return false;
      throw e;
    }
    if (n === 0) hangUp();
    arrived(n);
    return true;
  };
  // Waits for the host; false once it has closed the line.
  const wait = () => {
    for (;;) {
      let n;
      try {
        n = fs.readSync(0, chunk, 0, chunk.length, null);
      } catch (e) {
        if (e.code === "EAGAIN") { input.sleepMs(1); continue; }
        if (e.code === "EOF") return false;
        throw e;
      }
      if (n === 0) return false;
      arrived(n);
      return true;
    }
  };
  // For the REPL: the next byte, waiting (idle() first) when there is none;
  // null once the host has closed the line.
  input.next = (idle) => {
    while (!rx.length) {
      idle();
      if (!wait()) return null;
    }
    const c = rx[0];
    rx = rx.subarray(1);
    return c;
  };
  // For the REPL: the byte k places ahead, waiting for it; undefined at the end.
  input.peek = (k) => {
    while (rx.length <= k) if (!wait()) return undefined;
    return rx[k];
  };
  input.skip = (k) => { rx = rx.subarray(k); };
  // sys.stdin's read, as a board's: it waits until it has all it asked for.
  // A Ctrl-C while it waits ends it at once (EINTR: MicroPython raises the
  // KeyboardInterrupt there).
  input.read = (buffer, offset, length) => {
    let n = 0;
    while (n < length) {
      if (rx.length) {
        const k = Math.min(rx.length, length - n);
        buffer.set(rx.subarray(0, k), offset + n);
        rx = rx.subarray(k);
        n += k;
      } else if (input.interrupted) {
        break;
      } else if (!input.look()) {
        input.sleepMs(1);
      }
    }
    if (n === 0 && length > 0) {
      input.interrupted = false;
      throw new M.FS.ErrnoError(27); // Emscripten's EINTR
    }
    return n;
  };
  input.readable = () => rx.length > 0 || (input.look() && rx.length > 0);
  return input;
}

// The clock. MicroPython here runs synchronously on Node's only thread, so a
// running program never returns to read stdin; a board would see Ctrl-C in
// its USB interrupt. Date.now runs whenever MicroPython reads its clock or
// the file system stamps a file (any real main loop does either), so, while
// a program runs, it takes in what the host sent, at most every 10 ms.
// And the port's sleep_ms and select.poll's time-out spin on its clock
// (ticks, the import busyWait wraps below): after 20 readings within one
// millisecond the thread sleeps a millisecond, giving the core away.
function installClock(input, state) {
  const realNow = Date.now.bind(Date);
  let lastLook = 0;
  Date.now = () => {
    const t = realNow();
    if (state.running && t - lastLook >= 10) {
      lastLook = t;
      input.look();
    }
    return t;
  };
  let lastT = 0;
  let same = 0;
  return () => {
    const t = realNow();
    if (t !== lastT) {
      lastT = t;
      same = 0;
    } else if (++same >= 20) {
      same = 0;
      input.sleepMs(1);
    }
  };
}

// Bad writes. The flash is Emscripten's in-memory file system, which the
// interpreter's write() reaches through FS.write; wrapping it corrupts what
// is stored, not what was sent, so a host tool can only find out by
// reading the file back, as on a board.
function installBadWrites(mp, prefix, count) {
  const write = mp.FS.write;
  mp.FS.write = function (stream, buffer, offset, length, position, canOwn) {
    if (count > 0 && length > 0 && stream.path && stream.path.startsWith(prefix)) {
      count -= 1;
      const data = Uint8Array.from(buffer.subarray(offset, offset + length));
      data[0] ^= 1;
      return write.call(this, stream, data, 0, length, position, false);
    }
    return write.call(this, stream, buffer, offset, length, position, canOwn);
  };
}

// The interpreter's imports, wrapped as it is instantiated:
//
// - File errors with a board's numbers. Emscripten's file system speaks
//   WASI's errno (ENOENT is 44), which MicroPython raises as it is, so
//   OSError.errno matched nothing in the errno module and tracebacks said
//   "OSError: 44". A syscall's -errno and a WASI call's errno come back as
//   MicroPython's (mperrno.h, Linux's numbers), so the board prints and
//   compares what a Pico does. EINTR stays as it is: the interpreter
//   retries on its own number.
// - The clock: each reading of MicroPython's ticks calls hooks.onClock.
const BOARD_ERRNO = {
  63: 1, 44: 2, 29: 5, 8: 9, 6: 11, 48: 12, 2: 13, 10: 16, 20: 17, 43: 19, 54: 20,
  31: 21, 28: 22, 51: 28, 69: 30, 55: 39, 138: 95, 73: 110,
};

function wrapImports(hooks) {
  const instantiate = WebAssembly.instantiate;
  WebAssembly.instantiate = function (binary, imports) {
    const wrapped = {};
    for (const [mod, fns] of Object.entries(imports)) {
      wrapped[mod] = {};
      for (const [name, fn] of Object.entries(fns)) {
        if (typeof fn !== "function") wrapped[mod][name] = fn;
        else if (name.startsWith("__syscall_")) {
          wrapped[mod][name] = (...a) => { const r = fn(...a); return r < 0 && BOARD_ERRNO[-r] ? -BOARD_ERRNO[-r] : r; };
        } else if (name.startsWith("fd_")) {
          wrapped[mod][name] = (...a) => { const r = fn(...a); return r > 0 && BOARD_ERRNO[r] ? BOARD_ERRNO[r] : r; };
        } else if (name === "mp_js_ticks_ms") {
          wrapped[mod][name] = (...a) => { hooks.onClock(); return fn(...a); };
        } else wrapped[mod][name] = fn;
      }
    }
    WebAssembly.instantiate = instantiate;
    return instantiate.call(this, binary, wrapped);
  };
}

// The board's identity. sys.platform, sys.version and sys.implementation's
// _machine and _build are string objects in the interpreter's static data
// (id() gives their address): each is pointed at a copy of what a Pico 2
// answers, once, and stays so across soft resets. A string that is not
// where and what id() says is left alone. Returns os.uname()'s fields.
function patchIdentity(mp, identity) {
  const M = mp._module;
  mp.runPython(
    "import sys, json\n" +
    "__vb = json.dumps([[id(s), s] for s in (sys.platform, sys.version, " +
    "sys.implementation._machine, sys.implementation._build)] + " +
    "['%d.%d.%d' % sys.implementation.version[:3]])\ndel sys, json\n"
  );
  const found = JSON.parse(mp.globals.get("__vb"));
  mp.runPython("del __vb");
  const release = found.pop();
  const [, , , , date] = /^(.*MicroPython v)(\S+)( on )(\S+)/.exec(found[1][1]) || [];
  const version = "v" + release + (date ? " on " + date : "");
  const wanted = [identity.platform, "3.4.0; MicroPython " + version, identity.machine, identity.build];
  const heap = M.HEAPU8;
  const words = new Uint32Array(heap.buffer);
  found.forEach(([addr, old], i) => {
    const want = wanted[i];
    if (want === undefined || want === old) return;
    // mp_obj_str_t on wasm32: type, hash, len, data
    const w = addr >>> 2;
    const oldBytes = Buffer.from(old, "utf8");
    if (addr % 4 || words[w + 2] !== oldBytes.length ||
        Buffer.compare(Buffer.from(heap.subarray(words[w + 3], words[w + 3] + oldBytes.length)), oldBytes) !== 0) {
      process.stderr.write("virtual board: cannot set " + JSON.stringify(old) + " to " + JSON.stringify(want) + "\n");
      return;
    }
    const bytes = Buffer.from(want, "utf8");
    const data = M._malloc(bytes.length + 1);
    heap.set(bytes, data);
    heap[data + bytes.length] = 0;
    words[w + 1] = 0; // hash: computed on demand
    words[w + 2] = bytes.length;
    words[w + 3] = data;
  });
  return [identity.platform, identity.platform, release, version, identity.machine];
}

async function replMode() {
  const fsDir = process.argv[4];
  const heap = parseInt(process.argv[5] || "8388608", 10);
  const options = JSON.parse(process.argv[6] || "{}");
  if (options.nonblock_fd === undefined) {
    process.stderr.write("host.mjs repl: options need nonblock_fd (virtual_board.py passes it)\n");
    process.exit(2);
  }
  let muted = false;
  // Output the REPL prints about itself (its banner) is held and reworded.
  let held = null;
  const out = (b) => {
    if (muted) return;
    if (held) held.push(Buffer.from(b));
    else writeAll(Buffer.from(b));
  };
  const banner = options.identity ? (fn) => {
    held = [];
    try { return fn(); } finally {
      const text = Buffer.concat(held).toString("latin1");
      held = null;
      writeAll(Buffer.from(text.replace(
        /MicroPython v(\d+\.\d+\.\d+)\S* on (\S+); JS with Emscripten/,
        "MicroPython v$1 on $2; " + options.identity.machine), "latin1"));
    }
  } : (fn) => fn();
  const hooks = { onClock: () => {} };
  wrapImports(hooks);
  const mp = await loadMicroPython({
    heapsize: heap,
    linebuffer: false,
    // fd 0 becomes a device of its own, whose read and poll are ours (below)
    stdin: () => null,
    stdout: out,
    stderr: out,
  });
  const M = mp._module;
  mp.FS.mkdirTree(FLASH);
  loadTree(mp, fsDir, FLASH);
  if (options.bad_writes) installBadWrites(mp, FLASH + options.bad_writes[0], options.bad_writes[1]);
  const modules = options.modules || [];
  if (modules.length) mp.FS.mkdirTree(BUILTINS);
  for (const file of modules) {
    mp.FS.writeFile(path.posix.join(BUILTINS, path.basename(file)), fs.readFileSync(file));
  }
  const uname = options.identity ? patchIdentity(mp, options.identity) : null;

  const sync = () => {
    const seen = new Set();
    syncTree(mp, FLASH, fsDir, seen);
    pruneTree(fsDir, seen);
  };
  const state = { running: false };
  // The host closed the line: the board is unplugged, its flash kept.
  const hangUp = () => {
    sync();
    process.exit(0);
  };
  const input = serialInput(M, options.nonblock_fd, state, hangUp);
  hooks.onClock = installClock(input, state);
  const stdinOps = mp.FS.getStream(0).stream_ops;
  stdinOps.read = (stream, buffer, offset, length) => input.read(buffer, offset, length);
  stdinOps.poll = () => (input.readable() ? 1 : 0) | 4; // POLLIN, POLLOUT
  const running = (fn) => {
    state.running = true;
    try { return fn(); } finally { state.running = false; input.interrupted = false; }
  };

  // machine.reset() asks for a hard reset here, then raises SystemExit to
  // end the program; from then on the board says nothing, as a Pico whose
  // USB has gone.
  let resetRequest = null;
  // A program that caught the SystemExit carries on: the reset never was.
  const unmute = () => { resetRequest = null; muted = false; };

  // Per VM: the flash at "/", os, sys and input() as rp2 has them, the
  // built-in modules (pico2_start.py).
  const startCode = fs.readFileSync(new URL("pico2_start.py", import.meta.url), "utf8");
  const config = JSON.stringify({
    flash: FLASH,
    block: BLOCK,
    blocks: options.flash_bytes ? Math.floor(options.flash_bytes / BLOCK) : 0,
    uname,
    builtins: modules.map((f) => path.basename(f, ".py")),
    builtins_dir: BUILTINS,
  });
  const setup = () => {
    // New JS objects for each VM: one the VM before saw maps to a proxy in
    // that VM's freed heap.
    mp.registerJsModule("_vboard", {
      config,
      used: () => usedBlocks(mp, FLASH),
      sync: () => { sync(); },
      reset: () => { resetRequest = "hard"; muted = true; },
    });
    try {
      mp.runPython(startCode);
    } catch (e) {
      writeAll(Buffer.from(String(e.message).replace(/\r?\n/g, "\r\n"), "utf8"));
    }
  };

  // A script as a board runs boot.py and main.py: in the REPL's globals,
  // Ctrl-C interrupts it, its traceback names the file; null, or the reset
  // it asked for (SystemExit: machine.reset(), machine.soft_reset(),
  // sys.exit()).
  const runScript = (script) => {
    try { mp.FS.stat(path.posix.join(FLASH, script)); } catch (e) { return null; }
    try {
      running(() => mp.runPython(
        "__import__('micropython').kbd_intr(3)\n" +
        "try:\n" +
        "    exec(compile(open('" + script + "').read(), '" + script + "', 'exec'), globals())\n" +
        "finally:\n" +
        "    __import__('micropython').kbd_intr(-1)\n"
      ));
    } catch (e) {
      if (e.type === "SystemExit") return resetRequest || "soft";
      unmute();
      writeAll(Buffer.from(String(e.message).replace(/\r?\n/g, "\r\n"), "utf8"));
    }
    unmute();
    return null;
  };

  // Boot the way a board does: boot.py, then main.py unless the REPL is raw
  // (a host tool is driving it). A soft reset keeps the REPL's mode and says
  // so; a hard reset (machine.reset()) starts over in the friendly REPL, as
  // after power-on.
  let raw = false;
  const start = (reset) => {
    const pyexecRaw = raw;
    const powerOn = !reset || reset === "hard";
    for (;;) {
      if (reset) {
        sync();
        muted = false;
        if (reset === "soft") {
          writeAll(Buffer.from("MPY: soft reboot\r\n"));
        } else {
          raw = false;
          input.skip(input.available()); // the USB receive buffer goes with the reset
        }
        M.ccall("mp_js_init", "null", ["number", "number"], [2048, heap]);
        M.ccall("proxy_c_init", "null", [], []);
      }
      resetRequest = null;
      setup();
      reset = null;
      for (const script of raw ? ["boot.py"] : ["boot.py", "main.py"]) {
        reset = runScript(script);
        if (reset) break;
      }
      if (!reset) break;
    }
    if (pyexecRaw && !raw) {
      // The REPL itself remembers raw mode across a VM's re-initialisation.
      muted = true;
      mp.replInit();
      muted = false;
      banner(() => mp.replProcessChar(2));
    } else {
      banner(() => mp.replInit());
    }
    // For the host side only (virtual_board.py counts these): a Pico's USB
    // is gone from machine.reset() until it enumerates again, so a host tool
    // waits for the board to be back before it talks to it; over a
    // pseudo-terminal that stays open, this line is how it knows.
    if (powerOn) process.stderr.write("virtual board: up\n");
  };

  start(null);
  // Raw REPL: nothing received since its prompt, where raw-paste may be
  // asked for (Ctrl-E A Ctrl-A). The port mishandles raw-paste (it reads
  // the pasted code from a stdin it does not have), so the board answers
  // "R\x00", not supported, and the host falls back to the plain raw REPL.
  let fresh = false;
  for (;;) {
    const c = input.next(sync);
    if (c === null) break;
    if (raw && fresh && c === 5 && input.peek(0) === 0x41 && input.peek(1) === 1) {
      input.skip(2);
      writeAll(Buffer.from("R\x00", "latin1"));
      continue;
    }
    if (c === 1) raw = true;       // Ctrl-A: raw REPL
    else if (c === 2) raw = false; // Ctrl-B: friendly REPL
    // Ctrl-B runs nothing: it prints the banner
    const r = c === 2 ? banner(() => mp.replProcessChar(c)) : running(() => mp.replProcessChar(c));
    fresh = raw && (c === 1 || c === 4);
    if (!(r & 256) && resetRequest) unmute();
    if (r & 256) {
      // PYEXEC_FORCED_EXIT: a soft reset (Ctrl-D on an empty line, or
      // SystemExit), or machine.reset()'s hard one.
      start(resetRequest || "soft");
      fresh = raw;
    }
  }
  sync();
}

if (mode === "exec") await execMode();
else if (mode === "repl") await replMode();
else {
  process.stderr.write("usage: host.mjs exec|repl <micropython.mjs> ...\n");
  process.exit(2);
}
process.exit(0);
