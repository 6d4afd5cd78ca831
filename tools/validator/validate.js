// Runs the Khronos glTF validator on one .glb/.gltf and prints its report as JSON.
// Exit status: 0 when the report has no errors, 1 when it has errors, 2 when the
// validator could not run. Used by tests/slow/format_validator_test.cpp.
'use strict';
const fs = require('fs');
const path = require('path');
const validator = require('gltf-validator');

const file = process.argv[2];
if (!file) {
  console.error('usage: node validate.js FILE.glb');
  process.exit(2);
}
const bytes = new Uint8Array(fs.readFileSync(file));
validator
  .validateBytes(bytes, { uri: path.basename(file), maxIssues: 1000 })
  .then((report) => {
    console.log(JSON.stringify(report, null, 1));
    process.exit(report.issues.numErrors > 0 ? 1 : 0);
  })
  .catch((err) => {
    console.error('validator failed: ' + err);
    process.exit(2);
  });
