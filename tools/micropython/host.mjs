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
//       which handles the port's quirks on the byte stream. The file system
//       is loaded from fs_dir at start and written back after every input
//       chunk, so it outlives a restart like a board's flash does.
//       options_json (all optional):
//         interrupt_fd  a non-blocking pipe on which the host signals Ctrl-C
//                       while Python runs (see "Ctrl-C" below);
//         flash_bytes   capacity os.statvfs reports, as a board's flash does;
//         modules       host .py files the board offers like built-in modules
//                       (the twin's machine), outside the synced flash;
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
function syncTree(mp, mpDir, hostDir, seen, skip) {
  for (const name of mp.FS.readdir(mpDir)) {
    if (name === "." || name === ".." || (skip && skip.has(name))) continue;
    const m = path.posix.join(mpDir, name);
    const h = path.join(hostDir, name);
    const st = mp.FS.stat(m);
    seen.add(h);
    if (mp.FS.isDir(st.mode)) {
      fs.mkdirSync(h, { recursive: true });
      syncTree(mp, m, h, seen, null);
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

function usedBlocks(mp, dir, skip) {
  let blocks = 2;
  for (const name of mp.FS.readdir(dir)) {
    if (name === "." || name === ".." || (skip && skip.has(name))) continue;
    const p = path.posix.join(dir, name);
    const st = mp.FS.stat(p);
    if (mp.FS.isDir(st.mode)) blocks += usedBlocks(mp, p, null);
    else blocks += Math.max(1, Math.ceil(st.size / BLOCK));
  }
  return blocks;
}

// Ctrl-C. MicroPython here runs synchronously on Node's only thread, so a
// running program never returns to read stdin; a board would see Ctrl-C in
// its USB interrupt. The virtual board therefore also writes every Ctrl-C to
// a side pipe, and this hook, called whenever MicroPython reads its clock
// (ticks_ms, sleep_ms, file times: any real main loop does), polls that
// pipe at most every 10 ms and schedules a KeyboardInterrupt as a board's
// USB handler does. It polls only while Python runs (`state.running`), and
// signals left from idle times are dropped before each input chunk is
// processed, so only a Ctrl-C sent while code runs raises.
function installInterrupt(M, fd, state) {
  const realNow = Date.now.bind(Date);
  const buf = Buffer.alloc(64);
  let last = 0;
  const drain = () => {
    let hit = false;
    for (;;) {
      let n = 0;
      try { n = fs.readSync(fd, buf, 0, buf.length, null); } catch (e) { return hit; }
      if (n <= 0) return hit;
      hit = true;
    }
  };
  Date.now = () => {
    const t = realNow();
    if (state.running && t - last >= 10) {
      last = t;
      if (drain()) M._mp_sched_keyboard_interrupt();
    }
    return t;
  };
  return drain;
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

async function replMode() {
  const fsDir = process.argv[4];
  const heap = parseInt(process.argv[5] || "8388608", 10);
  const options = JSON.parse(process.argv[6] || "{}");
  // The board's flash is the root, as on rp2; Emscripten's own folders are
  // not part of it and are never synced.
  const ROOT = "/";
  const SYSTEM = new Set(["tmp", "home", "dev", "proc"]);
  // Built-in modules the board offers (the twin's machine) live here, on
  // the import path but outside the synced flash, as a board's frozen
  // modules are.
  const BUILTINS = "/home/roboray";
  const mp = await loadMicroPython({
    heapsize: heap,
    linebuffer: false,
    stdout: (b) => writeAll(Buffer.from(b)),
    stderr: (b) => writeAll(Buffer.from(b)),
  });
  const M = mp._module;
  loadTree(mp, fsDir, ROOT);
  if (options.bad_writes) installBadWrites(mp, options.bad_writes[0], options.bad_writes[1]);
  const modules = options.modules || [];
  if (modules.length) mp.FS.mkdirTree(BUILTINS);
  for (const file of modules) {
    mp.FS.writeFile(path.posix.join(BUILTINS, path.basename(file)), fs.readFileSync(file));
  }
  const state = { running: false };
  const dropInterrupts = options.interrupt_fd !== undefined
    ? installInterrupt(M, options.interrupt_fd, state) : () => false;
  const running = (fn) => {
    state.running = true;
    try { return fn(); } finally { state.running = false; }
  };

  const sync = () => {
    const seen = new Set();
    syncTree(mp, ROOT, fsDir, seen, SYSTEM);
    pruneTree(fsDir, seen);
  };

  // Per VM: what a board has built in. Registered again after each soft
  // reboot, which clears the VM's module table.
  const builtins = () => {
    let code = "";
    if (options.flash_bytes) {
      const total = Math.floor(options.flash_bytes / BLOCK);
      mp.registerJsModule("_vboard", { used: () => usedBlocks(mp, ROOT, SYSTEM) });
      code +=
        "import _vboard\n" +
        "def _statvfs(path, _used=_vboard.used):\n" +
        "    os.stat(path)\n" +
        "    free = max(0, " + total + " - _used())\n" +
        "    return (" + BLOCK + ", " + BLOCK + ", " + total + ", free, free, 0, 0, 0, 0, 255)\n" +
        "os.statvfs = _statvfs\n" +
        "del _statvfs, _vboard, sys.modules['_vboard']\n";
    }
    if (modules.length) code += "sys.path.insert(0, '" + BUILTINS + "')\n";
    return code;
  };

  // Boot the way a board does: cwd on the flash, boot.py, then main.py
  // unless the REPL is raw (a host tool is driving it).
  const boot = (rawMode) => {
    mp.runPython(
      "import os, sys\nos.chdir('" + ROOT + "')\n" +
      "sys.path.clear()\nsys.path.extend(['', '.frozen', '/lib'])\n" + builtins() +
      "del os, sys\n"
    );
    for (const script of rawMode ? ["boot.py"] : ["boot.py", "main.py"]) {
      let exists = true;
      try { mp.FS.stat(path.posix.join(ROOT, script)); } catch (e) { exists = false; }
      if (!exists) continue;
      try {
        running(() => mp.runPython("exec(open('" + script + "').read(), {'__name__': '__main__'})"));
      } catch (e) {
        writeAll(Buffer.from(String(e.message).replace(/\r?\n/g, "\r\n"), "utf8"));
      }
    }
  };

  let raw = false;
  boot(false);
  mp.replInit();
  for (;;) {
    const chunk = readChunk();
    if (chunk === null) break;
    dropInterrupts();
    for (const c of chunk) {
      if (c === 1) raw = true;       // Ctrl-A: raw REPL
      else if (c === 2) raw = false; // Ctrl-B: friendly REPL
      const r = running(() => mp.replProcessChar(c));
      if (r & 256) {
        // PYEXEC_FORCED_EXIT: Ctrl-D asked for a soft reset, which this port
        // leaves to its host. Re-initialise the VM on the same file system.
        sync();
        writeAll(Buffer.from("MPY: soft reboot\r\n"));
        M.ccall("mp_js_init", "null", ["number", "number"], [2048, heap]);
        M.ccall("proxy_c_init", "null", [], []);
        boot(raw);
        mp.replInit();
      }
    }
    sync();
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
