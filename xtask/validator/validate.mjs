// Runs Khronos glTF-Validator on each file named on the command line and
// prints one JSON line per file: {"file": ..., "report": {...}} or, when the
// validator could not process the file at all, {"file": ..., "error": "..."}.
// Used by `cargo xtask check-assets` (xtask/src/validate.rs), which judges the
// reports; this script exits non-zero only on bad usage.

import { readFile } from 'node:fs/promises';
import path from 'node:path';
import * as validator from 'gltf-validator';

const files = process.argv.slice(2);
if (files.length === 0) {
  console.error('usage: node validate.mjs FILE.gltf...');
  process.exit(2);
}

for (const file of files) {
  let line;
  try {
    const bytes = new Uint8Array(await readFile(file));
    const report = await validator.validateBytes(bytes, {
      uri: path.basename(file),
      maxIssues: 0, // unlimited
      writeTimestamp: false,
      externalResourceFunction: async (uri) =>
        new Uint8Array(await readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)))),
    });
    line = { file, report };
  } catch (error) {
    line = { file, error: String(error) };
  }
  console.log(JSON.stringify(line));
}
