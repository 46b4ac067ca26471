#!/usr/bin/env node
// SPDX-License-Identifier: GPL-3.0-or-later
//
// A recorder of Flamenco's job-compiler API, to compile a Flamenco job type under Node:
//
//     node flamenco_recorder.js JOB_TYPE.js [SETTINGS_JSON] [--name NAME]
//
// Loads JOB_TYPE.js with Node's `vm` module (in strict mode, as Flamenco Manager compiles its
// scripts), among the globals Flamenco gives a job compiler script: author.Task,
// author.Command, frameChunker, frameCount, formatTimestampLocal, print, alert and path
// (basename, dirname, join, stem). With SETTINGS_JSON (an object of job settings) it calls
// compileJob(job) and prints on stdout, as JSON:
//
//     {"job_type": JOB_TYPE, "name": ..., "settings": ..., "printed": [...],
//      "tasks": [{"name", "type", "priority", "commands": [{"name", "parameters"}],
//                 "dependencies": [names of the tasks it waits for]}]}
//
// Without SETTINGS_JSON it only checks JOB_TYPE and prints it ("tasks" is null).
// print() and alert() go to stderr, and into "printed".
//
// Misuse of the API is an error (exit status 1, the reason on stderr):
//   - a command name the Worker does not know, a parameter it does not take or of the
//     wrong type;
//   - a dependency on a task that was never added to the job, a dependency cycle;
//   - a task added twice, two tasks of the same name, a task with no commands;
//   - a command or a dependency given to a task after job.addTask(task) (Flamenco's job
//     keeps a copy of the task as it was then, so it would be lost);
//   - a malformed JOB_TYPE setting, and a job setting that JOB_TYPE does not declare, lacks
//     while it is required, or gives a value of the wrong type.
// Some checks are stricter than Flamenco (its Manager does not check the settings against
// JOB_TYPE, and its Worker would format a number in "args" with Go's %v): they are there to
// catch mistakes in a test. Wrong usage of this program: exit status 2.
//
// The behaviour follows Flamenco's documentation and its job compiler sources (the Go
// functions behind frameChunker and path); Flamenco runs the scripts in goja, not Node, so
// this is a stand-in, not the real runtime.
"use strict";

const fs = require("fs");
const nodePath = require("path");
const vm = require("vm");

class MisuseError extends Error {}

function misuse(message) {
    throw new MisuseError(message);
}

// --- Commands the Flamenco Worker runs, and their parameters ---------------------------
// "string!" and "number!" are required; "strings" is an array of strings; "array" an array
// of strings or numbers.
const COMMANDS = {
    "blender-render": { exe: "string!", exeArgs: "string", argsBefore: "strings", blendfile: "string",
                        args: "strings" },
    "exec": { exe: "string!", args: "strings" },
    "echo": { message: "string!" },
    "sleep": { duration_in_seconds: "number!" },
    "frames-to-video": { exe: "string!", exeArgs: "string", fps: "number!", inputGlob: "string!",
                         outputFile: "string!", argsBefore: "strings", args: "array" },
    "make-directory": { path: "string!" },
    "move-directory": { src: "string!", dest: "string!" },
    "copy-file": { src: "string!", dest: "string!" },
};

function checkParameters(commandName, parameters) {
    const spec = COMMANDS[commandName];
    if (parameters === null || typeof parameters !== "object" || Array.isArray(parameters)) {
        misuse(`author.Command("${commandName}", parameters): parameters must be an object`);
    }
    for (const key of Object.keys(parameters)) {
        if (!(key in spec)) {
            misuse(`command "${commandName}" has no parameter "${key}" ` +
                   `(it takes ${Object.keys(spec).join(", ")})`);
        }
    }
    for (const [key, kind] of Object.entries(spec)) {
        const value = parameters[key];
        const where = `command "${commandName}", parameter "${key}"`;
        if (value === undefined) {
            if (kind.endsWith("!")) {
                misuse(`${where} is required`);
            }
            continue;
        }
        const base = kind.replace("!", "");
        if (base === "string" && typeof value !== "string") {
            misuse(`${where} must be a string, not ${JSON.stringify(value)}`);
        }
        if (base === "string" && kind.endsWith("!") && value === "") {
            misuse(`${where} must not be empty`);
        }
        if (base === "number" && typeof value !== "number") {
            misuse(`${where} must be a number, not ${JSON.stringify(value)}`);
        }
        if (base === "strings" || base === "array") {
            if (!Array.isArray(value)) {
                misuse(`${where} must be an array, not ${JSON.stringify(value)}`);
            }
            for (const item of value) {
                const ok = typeof item === "string" || (base === "array" && typeof item === "number");
                if (!ok) {
                    misuse(`${where} must hold only strings, not ${JSON.stringify(item)}`);
                }
            }
        }
    }
}

// --- author: tasks and commands --------------------------------------------------------
const madeTasks = new WeakSet();
const madeCommands = new WeakSet();
const addedTasks = new WeakSet();

// Flamenco's job.addTask() stores a copy of the task (AuthoredJob.AddTask appends *task), so
// a command or a dependency given to the task afterwards would never reach the job.
function notYetAdded(task, what) {
    if (addedTasks.has(task)) {
        misuse(`task "${task.name}": ${what} after job.addTask(task); Flamenco's job holds a copy of ` +
               "the task made when it was added, so this would be lost (add the task last)");
    }
}

function nonEmpty(value, what) {
    if (typeof value !== "string" || value.trim() === "") {
        misuse(`${what} is required (a non-empty string), not ${JSON.stringify(value)}`);
    }
    return value.trim();
}

const author = Object.freeze({
    Task(name, taskType) {
        const task = {
            name: nonEmpty(name, "author.Task(name, type): name"),
            type: nonEmpty(taskType, `author.Task("${name}", type): type`),
            priority: 50,
            commands: [],
            dependencies: [],
            addCommand(command) {
                notYetAdded(task, "addCommand()");
                if (!madeCommands.has(command)) {
                    misuse(`task "${task.name}": addCommand() takes a command made by author.Command()`);
                }
                task.commands.push(command);
            },
            addDependency(other) {
                notYetAdded(task, "addDependency()");
                if (!madeTasks.has(other)) {
                    misuse(`task "${task.name}": addDependency() takes a task made by author.Task()`);
                }
                if (other === task) {
                    misuse(`task "${task.name}" cannot depend on itself`);
                }
                task.dependencies.push(other);
            },
        };
        madeTasks.add(task);
        return task;
    },
    Command(commandName, parameters, totalStepCount) {
        if (!Object.prototype.hasOwnProperty.call(COMMANDS, commandName)) {
            misuse(`unknown command "${commandName}"; the Worker runs ${Object.keys(COMMANDS).join(", ")}`);
        }
        if (totalStepCount !== undefined && !Number.isInteger(totalStepCount)) {
            misuse(`author.Command("${commandName}", ...): totalStepCount must be a whole number`);
        }
        checkParameters(commandName, parameters);
        // A deep copy: what the script changes afterwards does not reach the recorded command.
        const command = { name: commandName, parameters: JSON.parse(JSON.stringify(parameters)) };
        madeCommands.add(command);
        return command;
    },
});

// --- frameChunker and frameCount, as Flamenco Manager implements them -------------------
function invalidRange(range, message) {
    return new Error(`invalid range "${range}": ${message}`);
}

// The frames of "1-10,20..25,40": sorted, each once. Blender's ".." is read as "-".
function frameRangeExplode(frameRange) {
    const regular = frameRange.split("..").join("-");
    const frames = new Set();
    const parseInt10 = (text, part) => {
        const trimmed = text.trim();
        if (!/^[+-]?[0-9]+$/.test(trimmed)) {
            throw invalidRange(regular, part);
        }
        return Number(trimmed);
    };
    for (const part of regular.split(",")) {
        const startEnd = part.split("-");
        if (startEnd.length === 1) {
            frames.add(parseInt10(startEnd[0], part));
        } else if (startEnd.length === 2) {
            const first = parseInt10(startEnd[0], part);
            const last = parseInt10(startEnd[1], part);
            for (let frame = first; frame <= last; frame++) {
                frames.add(frame);
            }
        } else {
            throw invalidRange(regular, part);
        }
    }
    return [...frames].sort((a, b) => a - b);
}

// Consecutive frames merged, in "regular" notation: a run of one frame is "7", of two frames
// "7,8", of more "7-12".
function frameRangeMerge(frames) {
    const ranges = [];
    const append = (first, last) => {
        if (first === last) {
            ranges.push(`${first}`);
        } else if (first + 1 === last) {
            ranges.push(`${first}`, `${last}`);
        } else {
            ranges.push(`${first}-${last}`);
        }
    };
    let start = frames[0];
    let prev = frames[0];
    for (const frame of frames) {
        if (frame > prev + 1) {
            append(start, prev);
            start = frame;
        }
        prev = frame;
    }
    append(start, prev);
    return ranges.join(",");
}

function frameChunker(frameRange, chunkSize) {
    if (typeof frameRange !== "string") {
        misuse(`frameChunker(frames, chunkSize): frames must be a string, not ${JSON.stringify(frameRange)}`);
    }
    if (typeof chunkSize !== "number" || !Number.isInteger(chunkSize)) {
        misuse(`frameChunker(frames, chunkSize): chunkSize must be a whole number, not ${JSON.stringify(chunkSize)}`);
    }
    const trimmed = frameRange.trim();
    if (trimmed === "") {
        throw invalidRange(trimmed, "empty range");
    }
    if (chunkSize < 1) {
        throw new Error(`invalid chunk size, must be positive number: ${chunkSize}`);
    }
    const frames = frameRangeExplode(trimmed);
    if (frames.length === 0) {
        throw invalidRange(trimmed, "empty range");
    }
    const chunks = [];
    for (let i = 0; i < frames.length; i += chunkSize) {
        chunks.push(frameRangeMerge(frames.slice(i, i + chunkSize)));
    }
    return chunks;
}

function frameCount(frameRange) {
    return frameRangeExplode(String(frameRange)).length;
}

// --- path: Flamenco's cross-platform path functions (backslashes read as slashes) -------
const toSlash = (p) => String(p).split("\\").join("/");

function pathBase(p) {
    let slashed = toSlash(p);
    if (slashed === "") {
        return ".";
    }
    slashed = slashed.replace(/\/+$/, "");
    if (slashed === "") {
        return "/";
    }
    return slashed.slice(slashed.lastIndexOf("/") + 1);
}

// All but the last element, not cleaned (a UNC path's leading "//" stays).
function pathDir(p) {
    if (p === "") {
        return ".";
    }
    const slashed = toSlash(p);
    const dir = slashed.slice(0, slashed.lastIndexOf("/") + 1);
    if (dir === "") {
        return ".";
    }
    return dir.length > 1 ? dir.slice(0, -1) : dir;
}

// The non-empty elements joined with "/" and cleaned, like Go's path.Join.
function pathJoin(...elements) {
    const parts = elements.map(toSlash).filter((e) => e !== "");
    if (parts.length === 0) {
        return "";
    }
    const cleaned = nodePath.posix.normalize(parts.join("/"));
    return cleaned.length > 1 ? cleaned.replace(/\/+$/, "") : cleaned;
}

function pathStem(p) {
    const base = pathBase(p);
    const dot = base.lastIndexOf(".");
    return dot >= 0 ? base.slice(0, dot) : base;
}

const pathModule = Object.freeze({ basename: pathBase, dirname: pathDir, join: pathJoin, stem: pathStem });

// --- JOB_TYPE and the job's settings ----------------------------------------------------
const SETTING_FIELDS = new Set(["key", "type", "subtype", "choices", "propargs", "description", "default",
                                "eval", "evalInfo", "visible", "required", "editable", "label"]);
const SETTING_TYPES = new Set(["string", "int32", "float", "bool"]);
const SUBTYPES = new Set(["file_path", "dir_path", "file_name", "hashed_file_path"]);
const VISIBILITY = new Set(["visible", "hidden", "submission", "web"]);

function valueFits(type, value) {
    switch (type) {
    case "string": return typeof value === "string";
    case "int32": return Number.isInteger(value) && Math.abs(value) < 2 ** 31;
    case "float": return typeof value === "number";
    case "bool": return typeof value === "boolean";
    }
    return false;
}

function checkJobType(jobType) {
    if (jobType === null || typeof jobType !== "object") {
        misuse("the script does not define a JOB_TYPE object");
    }
    if (typeof jobType.label !== "string" || jobType.label === "") {
        misuse("JOB_TYPE.label must be a non-empty string");
    }
    if (!Array.isArray(jobType.settings)) {
        misuse("JOB_TYPE.settings must be an array");
    }
    const byKey = new Map();
    for (const setting of jobType.settings) {
        const key = setting && setting.key;
        if (typeof key !== "string" || key === "") {
            misuse(`a JOB_TYPE setting has no key: ${JSON.stringify(setting)}`);
        }
        if (byKey.has(key)) {
            misuse(`JOB_TYPE declares the setting "${key}" twice`);
        }
        for (const field of Object.keys(setting)) {
            if (!SETTING_FIELDS.has(field)) {
                misuse(`JOB_TYPE setting "${key}": unknown field "${field}"`);
            }
        }
        if (!SETTING_TYPES.has(setting.type)) {
            misuse(`JOB_TYPE setting "${key}": type must be one of ${[...SETTING_TYPES].join(", ")}`);
        }
        if (setting.subtype !== undefined && !SUBTYPES.has(setting.subtype)) {
            misuse(`JOB_TYPE setting "${key}": unknown subtype "${setting.subtype}"`);
        }
        if (setting.visible !== undefined && !VISIBILITY.has(setting.visible)) {
            misuse(`JOB_TYPE setting "${key}": visible must be one of ${[...VISIBILITY].join(", ")}`);
        }
        if (setting.choices !== undefined) {
            const ok = setting.type === "string" && Array.isArray(setting.choices) &&
                setting.choices.length > 0 && setting.choices.every((c) => typeof c === "string");
            if (!ok) {
                misuse(`JOB_TYPE setting "${key}": choices must be a non-empty array of strings, on a string setting`);
            }
        }
        if (setting.default !== undefined && !valueFits(setting.type, setting.default)) {
            misuse(`JOB_TYPE setting "${key}": default ${JSON.stringify(setting.default)} is not a ${setting.type}`);
        }
        if (setting.evalInfo !== undefined) {
            const info = setting.evalInfo;
            if (typeof info !== "object" || typeof info.showLinkButton !== "boolean" ||
                    typeof info.description !== "string") {
                misuse(`JOB_TYPE setting "${key}": evalInfo needs showLinkButton (bool) and description (string)`);
            }
        }
        byKey.set(key, setting);
    }
    return byKey;
}

function checkSettings(byKey, settings) {
    if (settings === null || typeof settings !== "object" || Array.isArray(settings)) {
        misuse("the job settings must be a JSON object");
    }
    for (const [key, value] of Object.entries(settings)) {
        const setting = byKey.get(key);
        if (setting === undefined) {
            misuse(`the job setting "${key}" is not declared by JOB_TYPE ` +
                   `(it declares ${[...byKey.keys()].join(", ")})`);
        }
        if (!valueFits(setting.type, value)) {
            misuse(`the job setting "${key}" must be a ${setting.type}, not ${JSON.stringify(value)}`);
        }
        if (setting.choices !== undefined && !setting.choices.includes(value)) {
            misuse(`the job setting "${key}" must be one of ${setting.choices.join(", ")}, not "${value}"`);
        }
    }
    for (const [key, setting] of byKey) {
        if (setting.required && !(key in settings)) {
            misuse(`the job setting "${key}" is required by JOB_TYPE`);
        }
    }
}

// --- The compiled job -------------------------------------------------------------------
function checkTasks(tasks) {
    const names = new Map();
    for (const task of tasks) {
        if (names.has(task.name)) {
            misuse(`two tasks are called "${task.name}"`);
        }
        names.set(task.name, task);
        if (task.commands.length === 0) {
            misuse(`task "${task.name}" has no commands`);
        }
    }
    const added = new Set(tasks);
    for (const task of tasks) {
        for (const dep of task.dependencies) {
            if (!added.has(dep)) {
                misuse(`task "${task.name}" depends on task "${dep.name}", which was not added to the job`);
            }
        }
    }
    // No cycles: depth-first, with the tasks on the current path marked.
    const state = new Map();
    const visit = (task, trail) => {
        if (state.get(task) === "done") {
            return;
        }
        if (state.get(task) === "open") {
            misuse(`dependency cycle: ${[...trail, task.name].join(" -> ")}`);
        }
        state.set(task, "open");
        for (const dep of task.dependencies) {
            visit(dep, [...trail, task.name]);
        }
        state.set(task, "done");
    };
    tasks.forEach((task) => visit(task, []));
}

function record(tasks) {
    return tasks.map((task) => ({
        name: task.name,
        type: task.type,
        priority: task.priority,
        commands: task.commands.map((c) => ({ name: c.name, parameters: c.parameters })),
        dependencies: task.dependencies.map((d) => d.name),
    }));
}

function formatTimestampLocal(date) {
    const d = date instanceof Date ? date : new Date(date);
    const two = (n) => String(n).padStart(2, "0");
    return `${d.getFullYear()}-${two(d.getMonth() + 1)}-${two(d.getDate())}_` +
        `${two(d.getHours())}${two(d.getMinutes())}${two(d.getSeconds())}`;
}

function main(argv) {
    const positional = [];
    let name = "recorded job";
    for (let i = 0; i < argv.length; i++) {
        if (argv[i] === "--name" && i + 1 < argv.length) {
            name = argv[++i];
        } else if (argv[i].startsWith("--")) {
            return usage(`unknown option ${argv[i]}`);
        } else {
            positional.push(argv[i]);
        }
    }
    if (positional.length < 1 || positional.length > 2) {
        return usage("give the job type file, and optionally the settings as JSON");
    }
    const [scriptFile, settingsJson] = positional;
    let settings = null;
    if (settingsJson !== undefined) {
        try {
            settings = JSON.parse(settingsJson);
        } catch (err) {
            return usage(`the settings are not JSON: ${err.message}`);
        }
    }

    const printed = [];
    const say = (...args) => {
        const line = args.map((a) => (typeof a === "string" ? a : JSON.stringify(a))).join(" ");
        printed.push(line);
        process.stderr.write(`print: ${line}\n`);
    };
    const context = vm.createContext({
        author,
        path: pathModule,
        frameChunker,
        frameCount,
        formatTimestampLocal,
        print: say,
        alert: say,
    });
    const source = fs.readFileSync(scriptFile, "utf8");
    // Strict mode, on the first line so that line numbers in errors stay the file's.
    vm.runInContext(`"use strict"; ${source}`, context, { filename: scriptFile });
    // `const JOB_TYPE` is a global binding but not a property of the global object.
    const jobType = vm.runInContext("typeof JOB_TYPE === 'undefined' ? undefined : JOB_TYPE", context);
    const byKey = checkJobType(jobType);
    const out = { job_type: JSON.parse(JSON.stringify(jobType)), name, settings, printed, tasks: null };

    if (settings !== null) {
        checkSettings(byKey, settings);
        const compileJob = vm.runInContext("typeof compileJob === 'undefined' ? undefined : compileJob", context);
        if (typeof compileJob !== "function") {
            misuse("the script does not define a compileJob(job) function");
        }
        const tasks = [];
        const job = {
            name,
            priority: 50,
            created: new Date(),
            settings: JSON.parse(JSON.stringify(settings)),
            metadata: {},
            addTask(task) {
                if (!madeTasks.has(task)) {
                    misuse("job.addTask() takes a task made by author.Task()");
                }
                if (tasks.includes(task)) {
                    misuse(`task "${task.name}" was added to the job twice`);
                }
                tasks.push(task);
                addedTasks.add(task);
            },
        };
        compileJob(job);
        checkTasks(tasks);
        out.settings = job.settings;
        out.tasks = record(tasks);
    }
    process.stdout.write(JSON.stringify(out, null, 2) + "\n");
    return 0;
}

function usage(message) {
    process.stderr.write(`flamenco_recorder: ${message}\n` +
        "usage: node flamenco_recorder.js JOB_TYPE.js [SETTINGS_JSON] [--name NAME]\n");
    return 2;
}

try {
    process.exitCode = main(process.argv.slice(2));
} catch (err) {
    const kind = err instanceof MisuseError ? "API misuse" : "error";
    // A job compiler script may throw a plain string, as Flamenco's own scripts do.
    // Errors made inside the script's context are not instances of this realm's Error.
    const message = err !== null && typeof err === "object" && typeof err.message === "string"
        ? err.message : String(err);
    process.stderr.write(`flamenco_recorder: ${kind}: ${message}\n`);
    process.exitCode = 1;
}
