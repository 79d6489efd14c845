// Validates glTF files with the Khronos glTF validator (npm gltf-validator), for
// tests/save_gltf.rs: prints one line per file, "<errors> <warnings> <path>", then each
// error's code, JSON pointer and message. Exits 0 when it could validate every file (the
// test judges the counts), 2 when the validator is not installed, 1 on other failures.
"use strict";
const fs = require("fs");
const path = require("path");
let validator;
try {
    validator = require("gltf-validator");
} catch (e) {
    console.error("gltf-validator is not installed (npm install -g gltf-validator)");
    process.exit(2);
}

async function validate(file) {
    const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
        uri: path.basename(file),
        maxIssues: 0,
        externalResourceFunction: (uri) =>
            new Promise((resolve, reject) => {
                fs.readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)), (err, data) =>
                    err ? reject(err.toString()) : resolve(new Uint8Array(data)));
            }),
    });
    const issues = report.issues;
    console.log(`${issues.numErrors} ${issues.numWarnings} ${file}`);
    for (const m of issues.messages.filter((m) => m.severity === 0)) {
        console.log(`  ${m.code} ${m.pointer || ""} ${m.message}`);
    }
}

(async () => {
    for (const file of process.argv.slice(2)) {
        await validate(file);
    }
})().catch((e) => {
    console.error(`validation failed: ${e}`);
    process.exit(1);
});
