// Validate glTF/GLB files with the Khronos glTF validator (npm `gltf-validator`).
// Prints the counts and every error and warning; exits 1 when a file has errors or warnings.
//   node tools/view/validate.mjs FILE.glb [FILE.glb …]
import { readFileSync } from "node:fs";
import { createRequire } from "node:module";

const require = createRequire(process.env.GLTF_VALIDATOR_DIR
  ? `${process.env.GLTF_VALIDATOR_DIR}/`
  : import.meta.url);
const validator = require("gltf-validator");
const severities = ["error", "warning", "info", "hint"];
let failed = false;
for (const file of process.argv.slice(2)) {
  const bytes = new Uint8Array(readFileSync(file));
  const report = await validator.validateBytes(bytes, { maxIssues: 1000 });
  const i = report.issues;
  console.log(
    `${file}: ${i.numErrors} errors, ${i.numWarnings} warnings, ${i.numInfos} infos, ${i.numHints} hints` +
      ` (${bytes.length} bytes; ${report.info?.animationCount ?? 0} animations, ` +
      `${report.info?.totalVertexCount ?? 0} vertices)`,
  );
  const counts = new Map();
  for (const m of i.messages) {
    if (m.severity > 1) continue;
    const key = `${severities[m.severity]} ${m.code}: ${m.message}`;
    const seen = counts.get(key);
    counts.set(key, { n: (seen?.n ?? 0) + 1, at: seen?.at ?? m.pointer });
  }
  for (const [key, { n, at }] of counts) {
    console.log(`  ${key} (${n}×, first at ${at})`);
  }
  if (i.numErrors > 0 || i.numWarnings > 0) failed = true;
}
process.exit(failed ? 1 : 0);
