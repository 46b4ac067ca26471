// SPDX-License-Identifier: GPL-3.0-or-later
//
// Flamenco job type "Expression Wrinkles" (see README.md in this folder).
//
// Three steps:
//   bake          one task, on a worker WITH the Expression Wrinkles extension:
//                 {blender} {blenderArgs} -c ewrinkles bake SHOT --frames A-B --save-as OUT/farm.blend
//                     --engine E --samples N --resolution W H
//   render-<range> one task per chunk of frames, each after the bake, WITHOUT the add-on:
//                 {blender} {blenderArgs} --factory-startup OUT/farm.blend --render-output
//                     OUT/frames/frame_#### --render-format PNG --use-extension 1 --render-frame 1..4
//   assemble      one task, after every render task, WITH the extension:
//                 {blender} {blenderArgs} -c ewrinkles sheet OUT/frames --frames A-B
//                     --out OUT/contact_sheet.png
//
// Every step uses the Worker's "blender-render" command, which runs
//     exe  exeArgs  argsBefore...  blendfile  args...
// in that order (exeArgs split like a shell would). Blender hands every argument after
// `-c NAME` to the command NAME, so `-c ewrinkles bake` goes in argsBefore and the shot in
// blendfile: the order that comes out is the one `ewrinkles bake SHOT ...` needs, and the
// `exec` command is not needed. The sheet has no blend file: its blendfile is empty, which
// the Worker leaves out of the command line (Flamenco 3.5 and newer).
//
// Task types decide which workers may run a task (a worker runs the types listed in its
// configuration). Both are "blender", like Flamenco's own job types; on a farm where only
// some workers have the extension, give the bake and the sheet a type of their own here
// (e.g. "blender-ewrinkles") and list it only on those workers.
const ADDON_TASK_TYPE = "blender";
const RENDER_TASK_TYPE = "blender";

const ENGINES = ["CYCLES", "EEVEE"];

const JOB_TYPE = {
    label: "Expression Wrinkles",
    description: "Bake the shot's wrinkles once (with the Expression Wrinkles extension), render its " +
        "frames in chunks on workers without the add-on, then assemble a contact sheet",
    settings: [
        // Settings for the artist:
        { key: "frames", type: "string", required: true,
          eval: "f'{C.scene.frame_start}-{C.scene.frame_end}'",
          evalInfo: { showLinkButton: true, description: "Scene frame range" },
          description: "Frames to render, e.g. '1-48' or '1-10,20-30'. The bake covers the first to the " +
              "last of them, the contact sheet shows them all" },
        { key: "chunk_size", type: "int32", default: 4, propargs: { min: 1 }, visible: "submission",
          description: "Number of frames to render in one render task" },
        { key: "render_output_root", type: "string", subtype: "dir_path", required: true,
          visible: "submission",
          description: "Folder for this job's output, on storage every worker can reach: farm.blend (the " +
              "baked shot), frames/frame_####.png and contact_sheet.png. Give each job its own folder" },
        { key: "engine", type: "string", required: true, choices: ENGINES, default: "CYCLES",
          eval: "'CYCLES' if C.scene.render.engine == 'CYCLES' else 'EEVEE'",
          evalInfo: { showLinkButton: true, description: "The scene's render engine" },
          description: "Render engine, stored in farm.blend by the bake" },
        { key: "samples", type: "int32", required: true, default: 64, propargs: { min: 1 },
          eval: "C.scene.cycles.samples if C.scene.render.engine == 'CYCLES' " +
              "else C.scene.eevee.taa_render_samples",
          evalInfo: { showLinkButton: true, description: "The scene's render samples" },
          description: "Render samples, stored in farm.blend by the bake" },
        { key: "resolution_x", type: "int32", required: true, default: 1920, propargs: { min: 4 },
          eval: "C.scene.render.resolution_x * C.scene.render.resolution_percentage // 100",
          evalInfo: { showLinkButton: true, description: "The scene's image width, at its percentage" },
          description: "Image width in pixels, stored in farm.blend (at 100%) by the bake" },
        { key: "resolution_y", type: "int32", required: true, default: 1080, propargs: { min: 4 },
          eval: "C.scene.render.resolution_y * C.scene.render.resolution_percentage // 100",
          evalInfo: { showLinkButton: true, description: "The scene's image height, at its percentage" },
          description: "Image height in pixels, stored in farm.blend (at 100%) by the bake" },

        // Set automatically. The Flamenco add-on replaces this with the path of the copy of the
        // shot it sends to the farm's storage. The shot is only read: the bake writes farm.blend.
        { key: "blendfile", type: "string", required: true, eval: "bpy.data.filepath", visible: "web",
          description: "Path of the shot's .blend file, read by the bake and never overwritten" },
    ],
};

function compileJob(job) {
    print("Expression Wrinkles job submitted");

    const settings = job.settings;
    const shot = stringSetting(settings, "blendfile");
    const out = stringSetting(settings, "render_output_root");
    const engine = stringSetting(settings, "engine");
    if (ENGINES.indexOf(engine) < 0) {
        throw `engine must be one of ${ENGINES.join(", ")}, not "${engine}"`;
    }
    const samples = wholeNumberSetting(settings, "samples", 1);
    const width = wholeNumberSetting(settings, "resolution_x", 4);
    const height = wholeNumberSetting(settings, "resolution_y", 4);
    const chunkSize = wholeNumberSetting(settings, "chunk_size", 1);
    const frameSpec = stringSetting(settings, "frames");
    const frames = framesOf(frameSpec);

    const farmBlend = path.join(out, "farm.blend");
    const framesDir = path.join(out, "frames");
    if (path.join(shot) === farmBlend) {
        throw `render_output_root holds the shot itself (${shot}): the bake would overwrite it`;
    }

    const bake = author.Task("bake", ADDON_TASK_TYPE);
    bake.addCommand(blenderCommand(["-c", "ewrinkles", "bake"], shot, [
        "--frames", `${frames[0]}-${frames[frames.length - 1]}`,
        "--save-as", farmBlend,
        "--engine", engine,
        "--samples", samples,
        "--resolution", width, height,
    ]));
    job.addTask(bake);

    // frameChunker returns each chunk in Flamenco's "regular" notation ("1-4", and two frames
    // as "9,10"); Blender's --render-frame wants "1..4". Each chunk is written out again from
    // its frames, so the task is called render-9-10 and renders "9..10".
    const renderTasks = [];
    const chunks = frameChunker(frameSpec, Number(chunkSize));
    for (let i = 0; i < chunks.length; i++) {
        const chunkFrames = framesOf(chunks[i]);
        const task = author.Task(`render-${rangeText(chunkFrames, "-")}`, RENDER_TASK_TYPE);
        // --factory-startup: no add-on is loaded, so the render needs only what farm.blend holds.
        task.addCommand(blenderCommand(["--factory-startup"], farmBlend, [
            "--render-output", path.join(framesDir, "frame_####"),
            "--render-format", "PNG",
            "--use-extension", "1",
            "--render-frame", rangeText(chunkFrames, ".."),
        ]));
        task.addDependency(bake);
        job.addTask(task);
        renderTasks.push(task);
    }

    const assemble = author.Task("assemble", ADDON_TASK_TYPE);
    assemble.addCommand(blenderCommand(["-c", "ewrinkles", "sheet"], "", [
        framesDir,
        "--frames", rangeText(frames, "-"),
        "--out", path.join(out, "contact_sheet.png"),
    ]));
    for (const task of renderTasks) {
        assemble.addDependency(task);
    }
    job.addTask(assemble);

    print(`${renderTasks.length} render tasks of at most ${chunkSize} frames, into ${out}`);
}

// A blender-render command with Flamenco's Blender: the Manager's {blender} and {blenderArgs}
// variables (by default "blender" and "-b -y") become the executable and its first arguments.
function blenderCommand(argsBefore, blendfile, args) {
    return author.Command("blender-render", {
        exe: "{blender}",
        exeArgs: "{blenderArgs}",
        argsBefore: argsBefore,
        blendfile: blendfile,
        args: args,
    });
}

function stringSetting(settings, key) {
    const value = settings[key];
    if (typeof value !== "string" || value.trim() === "") {
        throw `the ${key} setting is missing or empty`;
    }
    return value.trim();
}

// The setting as command-line text, after checking it is a whole number of at least `min`.
// A setting the submitter left out gets its default from JOB_TYPE.
function wholeNumberSetting(settings, key, min) {
    let value = settings[key];
    if (value === undefined || value === null || value === "") {
        for (const setting of JOB_TYPE.settings) {
            if (setting.key === key) {
                value = setting.default;
            }
        }
    }
    const number = Number(value);
    if (!Number.isInteger(number) || number < min) {
        throw `the ${key} setting must be a whole number of at least ${min}, not "${value}"`;
    }
    return String(number);
}

// The frames of a range in Flamenco's syntax ("1-10,20", "1..10"), in order, each once.
// frameChunker with chunks of one frame does the parsing, so it is Flamenco's own.
function framesOf(frameRange) {
    const single = frameChunker(frameRange, 1);
    const frames = [];
    for (let i = 0; i < single.length; i++) {
        frames.push(Number(single[i]));
    }
    if (frames.length === 0) {
        throw `no frames in "${frameRange}"`;
    }
    return frames;
}

// Sorted frames as text, each run of consecutive frames as FIRST<sep>LAST, commas between:
// ([1, 2, 3, 7], "..") gives "1..3,7".
function rangeText(frames, sep) {
    const parts = [];
    let start = 0;
    for (let i = 1; i <= frames.length; i++) {
        if (i === frames.length || frames[i] !== frames[i - 1] + 1) {
            const first = frames[start];
            const last = frames[i - 1];
            parts.push(first === last ? `${first}` : `${first}${sep}${last}`);
            start = i;
        }
    }
    return parts.join(",");
}
