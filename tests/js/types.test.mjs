// SPDX-License-Identifier: Apache-2.0
// The library's TypeScript declarations: satellite/js/types/ is what tsc makes of src/'s JSDoc
// (no drift), and examples/every-export.ts, which names every export, type-checks against them
// (tsc --noEmit, strict). TypeScript comes from satellite/js/node_modules (tools/bootstrap.sh).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { execFile } from 'node:child_process';
import { existsSync, mkdtempSync, readdirSync, readFileSync, rmSync } from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { promisify } from 'node:util';
import { fileURLToPath } from 'node:url';

const run = promisify(execFile);
const lib = fileURLToPath(new URL('../../satellite/js/', import.meta.url));
const tsc = path.join(lib, 'node_modules/.bin/tsc');

test('TypeScript is installed (tools/bootstrap.sh: npm ci --prefix satellite/js)', () => {
  assert.ok(existsSync(tsc), `${tsc} is missing: run tools/bootstrap.sh`);
});

test('types/ is what tsc makes of the JSDoc of src/ (regenerate: npm run types in satellite/js)', async () => {
  const out = mkdtempSync(path.join(os.tmpdir(), 'skrobot-types-'));
  try {
    await run(tsc, ['-p', path.join(lib, 'tsconfig.json'), '--outDir', out], { cwd: lib });
    const made = readdirSync(out).sort();
    assert.deepEqual(readdirSync(path.join(lib, 'types')).sort(), made);
    for (const f of made) {
      assert.equal(readFileSync(path.join(lib, 'types', f), 'utf8'), readFileSync(path.join(out, f), 'utf8'), `types/${f} differs`);
    }
  } finally {
    rmSync(out, { recursive: true, force: true });
  }
});

test('examples/every-export.ts type-checks against the declarations (strict)', async () => {
  try {
    await run(tsc, ['-p', path.join(lib, 'examples')], { cwd: lib });
  } catch (e) {
    assert.fail(`tsc --noEmit failed:\n${e.stdout}${e.stderr}`);
  }
});
