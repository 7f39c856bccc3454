// SPDX-License-Identifier: Apache-2.0
// What the WebSocket benchmarks share: the hub binary and module directory (environment, else the
// release build beside this checkout), command-line flags, percentiles, and a process's CPU time
// from /proc.
import { existsSync, readFileSync, readdirSync, rmSync } from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

export const repo = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');

// tests/web/harness.mjs reads its paths from the environment when it is imported: set them first.
export async function harness() {
  const release = path.join(repo, 'build/release');
  process.env.SKROBOT_BIN ??= path.join(release, 'bin/skrobot');
  process.env.SKROBOT_MODULE_DIR ??= path.join(release, 'modules');
  if (!existsSync(process.env.SKROBOT_BIN)) {
    throw new Error(`no hub at ${process.env.SKROBOT_BIN}: build it (cmake --preset release) or set SKROBOT_BIN`);
  }
  return import('../../tests/web/harness.mjs');
}

// --flag and --name value pairs: { quick: true, count: '500' }.
export function flags(argv = process.argv.slice(2)) {
  const out = {};
  for (let i = 0; i < argv.length; i++) {
    const a = argv[i];
    if (!a.startsWith('--')) throw new Error(`unexpected argument ${a}`);
    const key = a.slice(2);
    if (i + 1 < argv.length && !argv[i + 1].startsWith('--')) out[key] = argv[++i];
    else out[key] = true;
  }
  return out;
}

// The p-th percentile (0..100) of sorted numbers, nearest rank.
export function percentile(sorted, p) {
  if (!sorted.length) return NaN;
  const rank = Math.ceil((p / 100) * sorted.length);
  return sorted[Math.min(sorted.length - 1, Math.max(0, rank - 1))];
}

const TICKS_PER_SECOND = 100;  // USER_HZ, the unit of /proc/<pid>/stat's times on Linux

// /proc/<pid>/stat: the command name, the parent and utime + stime in seconds (threads together).
function stat(pid) {
  const text = readFileSync(`/proc/${pid}/stat`, 'utf8');
  // The command name may hold spaces: fields are counted after its closing parenthesis.
  const fields = text.slice(text.lastIndexOf(')') + 2).split(' ');
  return {
    comm: text.slice(text.indexOf('(') + 1, text.lastIndexOf(')')), ppid: Number(fields[1]),
    cpu: (Number(fields[11]) + Number(fields[12])) / TICKS_PER_SECOND,
  };
}

// utime + stime of a process in seconds.
export function cpuSeconds(pid) {
  return stat(pid).cpu;
}

// utime + stime of the descendants of `root` whose command name matches `comm`, in seconds (the
// processes alive now: one that ended between two readings takes its time with it).
export function treeCpuSeconds(root, comm) {
  const all = new Map();
  for (const d of readdirSync('/proc')) {
    if (!/^\d+$/.test(d)) continue;
    try {
      all.set(Number(d), stat(d));
    } catch {
      // ended meanwhile
    }
  }
  let sum = 0;
  for (const [pid, s] of all) {
    let p = s.ppid;
    while (p > 1 && p !== root) p = all.get(p)?.ppid ?? 0;
    if (p === root && pid !== root && comm.test(s.comm)) sum += s.cpu;
  }
  return sum;
}

// Kills `proc` (SIGKILL) if it is still running when this process exits, however it exits (an
// uncaught error included), and removes `dir` (a hub's): no hub or publisher outlives the
// benchmark.
export function killOnExit(proc, dir) {
  process.on('exit', () => {
    if (proc.exitCode === null && proc.signalCode === null) proc.kill('SIGKILL');
    if (dir) rmSync(dir, { recursive: true, force: true });
  });
}

export const fmt = (x, digits = 1) => (Number.isFinite(x) ? x.toFixed(digits) : '-');
