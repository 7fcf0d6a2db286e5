// SPDX-License-Identifier: GPL-3.0-or-later
//
// Compiles a Flamenco job type under Node.js with Flamenco Manager's job-authoring globals
// stubbed (author.Task, author.Command, frameChunker, path, print, formatTimestampLocal), as the
// Manager's JavaScript runtime provides them, and prints the compiled job as JSON.
//
// Usage: node flamenco_harness.js JOB_TYPE.js '{"settings": {...}}'
// Prints {"job_type", "python", "tasks": [{name, type, commands, dependencies}], "settings",
// "printed"} or {"error": "..."} when compileJob throws.

"use strict";
const fs = require("fs");
const nodePath = require("path").posix;
const vm = require("vm");

// Flamenco's frameChunker: explode the range, cut it into chunks of chunkSize frames, and write
// each chunk as merged "A-B" ranges joined by commas.
function explode(frames) {
    const result = new Set();
    for (const part of `${frames}`.split(",")) {
        const text = part.trim();
        if (!text) continue;
        const match = /^(-?\d+)(?:(?:-|\.\.)(-?\d+))?$/.exec(text);
        if (!match) throw `invalid range "${frames}"`;
        const first = parseInt(match[1], 10);
        const last = match[2] === undefined ? first : parseInt(match[2], 10);
        for (let frame = first; frame <= last; frame++) result.add(frame);
    }
    return [...result].sort((a, b) => a - b);
}

function merge(frames) {
    const parts = [];
    let start = frames[0], previous = frames[0];
    for (const frame of frames.slice(1).concat([null])) {
        if (frame !== null && frame === previous + 1) {
            previous = frame;
            continue;
        }
        parts.push(start === previous ? `${start}` : `${start}-${previous}`);
        start = previous = frame;
    }
    return parts.join(",");
}

function frameChunker(frames, chunkSize) {
    const all = explode(frames);
    if (!all.length) throw "empty range";
    if (chunkSize < 1) throw `invalid chunk size, must be positive number: ${chunkSize}`;
    const chunks = [];
    for (let i = 0; i < all.length; i += chunkSize) chunks.push(merge(all.slice(i, i + chunkSize)));
    return chunks;
}

class Task {
    constructor(name, type) {
        this.name = name;
        this.type = type;
        this.commands = [];
        this.dependencies = [];
    }
    addCommand(command) { this.commands.push(command); }
    addDependency(task) { this.dependencies.push(task); }
}

const printed = [];
const sandbox = {
    author: {
        Task: (name, type) => new Task(name, type),
        Command: (name, parameters) => ({ name: name, parameters: parameters }),
    },
    frameChunker: frameChunker,
    formatTimestampLocal: (date) => "2024-05-06_070809",
    path: {
        join: (...parts) => nodePath.join(...parts),
        dirname: (p) => nodePath.dirname(p),
        basename: (p) => nodePath.basename(p),
        stem: (p) => nodePath.basename(p, nodePath.extname(p)),
    },
    print: (...args) => printed.push(args.map((a) => typeof a === "string" ? a : JSON.stringify(a)).join(" ")),
};
vm.createContext(sandbox);

const [jobTypeFile, jobJson] = process.argv.slice(2);
const source = fs.readFileSync(jobTypeFile, "utf8");
const exported = vm.runInContext(
    source + "\n;({JOB_TYPE, compileJob, python: {ENGINE_CHECK_PY, TIMING_PY, MERGE_PY}})", sandbox,
    { filename: jobTypeFile });

const job = JSON.parse(jobJson);
job.created = new Date(0);
job.tasks = [];
job.addTask = (task) => job.tasks.push(task);
let error = null;
try {
    exported.compileJob(job);
} catch (exc) {
    error = `${exc}`;
}
process.stdout.write(JSON.stringify({
    error: error,
    job_type: exported.JOB_TYPE,
    python: exported.python,
    settings: job.settings,
    printed: printed,
    tasks: job.tasks.map((task) => ({
        name: task.name, type: task.type, commands: task.commands,
        dependencies: task.dependencies.map((dep) => dep.name),
    })),
}));
