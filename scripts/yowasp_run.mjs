// Runs a YoWASP tool (yosys or nextpnr-ice40 built for WebAssembly, from npm) on the real file
// system: the tool sees the given directories at their own absolute paths, and every file it
// writes under them is written back to disk.
//
// Usage: node scripts/yowasp_run.mjs yosys|nextpnr-ice40 --mount DIR [--mount DIR]... -- ARGS...
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
  if (option !== "--mount" || !argv.length) {
    console.error(`yowasp_run: expected --mount DIR or --, got ${option}`);
    process.exit(2);
  }
  mounts.push(path.resolve(argv.shift()));
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

// The tree of the mounted directories, at their absolute paths; sizes/mtimes kept to see writes.
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
  fs.mkdirSync(mount, { recursive: true });
  const parts = mount.split(path.sep).filter(Boolean);
  let node = tree;
  for (const part of parts.slice(0, -1)) node = node[part] ??= {};
  node[parts[parts.length - 1]] = readDirectory(mount);
}

function writeBack(node, dir) {
  for (const [entryName, value] of Object.entries(node)) {
    const full = path.join(dir, entryName);
    if (value instanceof Uint8Array || typeof value === "string") {
      if (!mounts.some((m) => full.startsWith(m + path.sep))) continue;
      const data = typeof value === "string" ? Buffer.from(value) : Buffer.from(value);
      const old = before.get(full);
      if (old && old.equals(data)) continue;
      fs.mkdirSync(dir, { recursive: true });
      fs.writeFileSync(full, data);
    } else {
      writeBack(value, full);
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
