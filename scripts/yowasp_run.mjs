// Runs a YoWASP tool (yosys or nextpnr-ice40 built for WebAssembly, from npm) on the real file
// system: the tool sees the given directories at their own absolute paths, and every file it
// writes under them is written back to disk.
//
// Usage: node scripts/yowasp_run.mjs yosys|nextpnr-ice40 [--mount DIR | --relative DIR]... -- ARGS...
//   --mount DIR: DIR at its absolute path; --relative DIR (a path relative to the current
//   directory): DIR at that relative path from the tool's working directory, so that a tool given
//   relative paths (gate_level_netlist.sh) names its files as they are named on disk.
//   The packages are found in $DELTA_YOWASP (default ~/.cache/delta-yowasp/node_modules, where
//   scripts/setup.sh installs them). Exit code: the tool's.
import fs from "node:fs";
import os from "node:os";
import path from "node:path";
import { pathToFileURL } from "node:url";

const argv = process.argv.slice(2);
const tool = argv.shift();
const mounts = [];
while (argv.length && argv[0] !== "--") {
  const option = argv.shift();
  if ((option !== "--mount" && option !== "--relative") || !argv.length) {
    console.error(`yowasp_run: expected --mount DIR, --relative DIR or --, got ${option}`);
    process.exit(2);
  }
  const dir = argv.shift();
  if (option === "--relative" && (path.isAbsolute(dir) || path.normalize(dir).startsWith(".."))) {
    console.error(`yowasp_run: --relative ${dir}: not a directory below the current one`);
    process.exit(2);
  }
  // The tool's working directory is its tree's root.
  const disk = path.resolve(dir);
  mounts.push({ disk, at: option === "--relative" ? path.join("/", path.normalize(dir)) : disk });
}
argv.shift();
const packages = { yosys: ["@yowasp/yosys", "runYosys"], "nextpnr-ice40": ["@yowasp/nextpnr-ice40", "runNextpnrIce40"] };
if (!packages[tool]) {
  console.error(`yowasp_run: unknown tool ${tool} (yosys or nextpnr-ice40)`);
  process.exit(2);
}
const root = process.env.DELTA_YOWASP || path.join(os.homedir(), ".cache/delta-yowasp/node_modules");
const [name, entry] = packages[tool];
const bundle = path.join(root, name, "gen/bundle.js");
if (!fs.existsSync(bundle)) {
  console.error(`yowasp_run: ${bundle}: not installed (run scripts/setup.sh)`);
  process.exit(2);
}
const module = await import(pathToFileURL(bundle).href);

// The tree of the mounted directories; their files' contents kept to see writes.
const tree = {};
const before = new Map();
function readDirectory(dir) {
  const node = {};
  for (const entry of fs.readdirSync(dir, { withFileTypes: true })) {
    const full = path.join(dir, entry.name);
    if (entry.isDirectory()) node[entry.name] = readDirectory(full);
    else if (entry.isFile()) {
      const data = fs.readFileSync(full);
      node[entry.name] = new Uint8Array(data.buffer, data.byteOffset, data.length);
      before.set(full, data);
    }
  }
  return node;
}
for (const mount of mounts) {
  fs.mkdirSync(mount.disk, { recursive: true });
  const parts = mount.at.split(path.sep).filter(Boolean);
  let node = tree;
  for (const part of parts.slice(0, -1)) node = node[part] ??= {};
  node[parts[parts.length - 1]] = readDirectory(mount.disk);
}

// A file the tool names `at` is on disk at the mount's `disk` path; files outside every mount
// (the tool's scratch files) are not written.
function diskPath(at) {
  const mount = mounts.find((m) => at.startsWith(m.at + path.sep));
  return mount ? path.join(mount.disk, path.relative(mount.at, at)) : null;
}
function writeBack(node, dir) {
  for (const [entryName, value] of Object.entries(node)) {
    const at = path.join(dir, entryName);
    if (value instanceof Uint8Array || typeof value === "string") {
      const full = diskPath(at);
      if (!full) continue;
      const data = typeof value === "string" ? Buffer.from(value) : Buffer.from(value);
      const old = before.get(full);
      if (old && old.equals(data)) continue;
      fs.mkdirSync(path.dirname(full), { recursive: true });
      fs.writeFileSync(full, data);
    } else {
      writeBack(value, at);
    }
  }
}

const write = (stream) => (bytes) => { if (bytes) stream.write(bytes); };
let code = 0;
let files;
try {
  files = await module[entry](argv, tree, { stdout: write(process.stdout), stderr: write(process.stderr), decodeASCII: false });
} catch (error) {
  if (error.files === undefined) throw error;
  files = error.files;
  code = error.code ?? 1;
}
writeBack(files, "/");
process.exit(code);
