// The Khronos glTF validator on one .glb or .gltf: prints its report's counts and messages
// as one JSON object.  Run by tests/blender/test_export_gltf.py:  node validate.js FILE
const fs = require('fs');
const path = require('path');
const validator = require('gltf-validator');

const file = process.argv[2];
const options = {
    maxIssues: 200,
    externalResourceFunction: (uri) => new Promise((resolve, reject) => {
        fs.readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)), (err, data) => {
            if (err) reject(err.toString()); else resolve(new Uint8Array(data));
        });
    }),
};
const run = file.toLowerCase().endsWith('.gltf')
    ? validator.validateString(fs.readFileSync(file, 'utf8'), options)
    : validator.validateBytes(new Uint8Array(fs.readFileSync(file)), options);
run.then((report) => {
    const issues = report.issues;
    console.log(JSON.stringify({
        errors: issues.numErrors, warnings: issues.numWarnings, infos: issues.numInfos,
        messages: issues.messages.map((m) => ({severity: m.severity, code: m.code, message: m.message,
                                              pointer: m.pointer})),
        info: report.info,
    }));
}, (err) => { console.error(String(err)); process.exit(1); });
