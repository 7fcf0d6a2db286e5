// SPDX-License-Identifier: GPL-3.0-or-later
//
// Hybrid RT Render: a Flamenco 3 job type that renders an animation with the Hybrid RT engine.
//
// Install: copy this one file into Flamenco Manager's `scripts/` folder (next to the Manager's
// executable) and restart the Manager; the job type then appears in the Blender add-on's
// submission panel. Workers need the Hybrid RT extension installed and enabled (docs/FARM.md).
//
// Each chunk of frames runs one Blender that first checks, in Python, that the Hybrid RT engine
// is registered on that worker and that the file's scene renders with it. Without the check a
// worker whose extension is missing (or disabled by --factory-startup) would switch the file to
// EEVEE and finish every frame: a wrong render that looks like a good one. With the check the
// task fails, and the task log says why.
//
// With "Timing Reports" each chunk also writes the timing report of its frames, and a final task
// (after every chunk) merges them into one report next to the frames.

const ENGINE_ID = "HYBRID_RT";
// Chunk reports go in a folder of their own, so that the merge reads exactly them.
const TIMING_CHUNKS_DIR = "hybrid_rt_timing_chunks";
const TIMING_PREFIX = "hybrid_rt_timing";

const JOB_TYPE = {
    label: "Hybrid RT Render",
    description: "Render frames with the Hybrid RT engine; a worker without it fails the task",
    settings: [
        // Settings for artists to determine:
        { key: "frames", type: "string", required: true,
          eval: "f'{C.scene.frame_start}-{C.scene.frame_end}'",
          evalInfo: { showLinkButton: true, description: "Scene frame range" },
          description: "Frames to render, e.g. '47', '1-30', '3, 5-10, 47-327'" },
        { key: "chunk_size", type: "int32", default: 1, propargs: { min: 1 }, visible: "submission",
          description: "Frames one Blender process renders (one task)" },
        { key: "timing_reports", type: "bool", default: false, visible: "submission",
          description: "Also write each frame's Hybrid RT timing report next to the frames, and merge them into one " +
                       "report at the end (renders every frame a second time, unrecorded warm-up included)" },

        // render_output_root + add_path_components determine render_output_path.
        { key: "render_output_root", type: "string", subtype: "dir_path", required: true, visible: "submission",
          description: "Base folder of the render output; job-specific parts are appended to it" },
        { key: "add_path_components", type: "int32", required: true, default: 0, propargs: { min: 0, max: 32 },
          visible: "submission",
          description: "Number of path components of the blend file's folder to use in the render output path" },
        { key: "render_output_path", type: "string", subtype: "file_path", editable: false,
          eval: "str(Path(abspath(settings.render_output_root), last_n_dir_parts(settings.add_path_components), jobname, '{timestamp}', '######'))",
          description: "Final file path of the frames" },

        // Evaluated from the file by the submitting Blender:
        { key: "blendfile", type: "string", required: true, description: "Path of the blend file to render",
          visible: "web" },
        { key: "format", type: "string", required: true, eval: "C.scene.render.image_settings.file_format",
          visible: "web" },
        { key: "image_file_extension", type: "string", required: true, eval: "C.scene.render.file_extension",
          visible: "hidden", description: "File extension of the frames" },
        { key: "engine", type: "string", eval: "C.scene.render.engine", visible: "hidden",
          description: "The render engine of the submitted scene" },
    ],
};

// Runs in every chunk's Blender after the file is loaded and before any frame is rendered
// (Blender's --python-expr; --python-exit-code makes an exception end Blender with that code).
// Kept free of backticks and "${" so that it stays a plain JavaScript template string.
const ENGINE_CHECK_PY = `
import bpy


def hybrid_rt_registered_engines(cls=bpy.types.RenderEngine):
    """Identifiers of the render engines registered in this Blender session."""
    found = set()
    for sub in cls.__subclasses__():
        if getattr(sub, "is_registered", False) and getattr(sub, "bl_idname", None):
            found.add(sub.bl_idname)
        found |= hybrid_rt_registered_engines(sub)
    return found


def hybrid_rt_engine_check():
    """Fail the task unless this worker can render the scene with Hybrid RT."""
    where = bpy.data.filepath or "the file"
    if "HYBRID_RT" not in hybrid_rt_registered_engines():
        raise RuntimeError(
            "Hybrid RT farm check failed: the Hybrid RT render engine is not registered on this "
            "worker, so Blender would render " + where + " with another engine. Install and enable "
            "the Hybrid RT extension for the user that runs the Flamenco Worker, and do not start "
            "Blender with --factory-startup, which disables extensions (docs/FARM.md).")
    scene = bpy.context.scene
    if scene.render.engine != "HYBRID_RT":
        raise RuntimeError(
            "Hybrid RT farm check failed: the scene '" + scene.name + "' of " + where + " renders "
            "with " + scene.render.engine + ", not Hybrid RT. Choose Hybrid RT as the Render Engine "
            "and save the file, or submit it with another job type.")
    print("Hybrid RT farm check passed: scene '" + scene.name + "' renders with Hybrid RT")


hybrid_rt_engine_check()
`;

// Writes the timing report of the ranges given in HYBRID_RT_TIMING (set above it) after the
// chunk's frames were rendered. The report never creates folders, so this creates its own.
const TIMING_PY = `
import os
import bpy

os.makedirs(HYBRID_RT_TIMING["folder"], exist_ok=True)
for first, last, prefix in HYBRID_RT_TIMING["ranges"]:
    if bpy.ops.hybrid_rt.timing_report(filepath=prefix, frame_start=first, frame_end=last) != {"FINISHED"}:
        raise RuntimeError("Hybrid RT timing report of frames " + str(first) + "-" + str(last) + " failed")
`;

// Merges the chunk reports of HYBRID_RT_MERGE["folder"] with the installed extension's
// hybrid_engine.reports.timing_merge (scripts/merge_timing_reports.py does the same from a
// checkout), writing the PNG chart with Blender's image writer as a single report does.
const MERGE_PY = `
import importlib
import bpy

names = [name for name in bpy.context.preferences.addons.keys()
         if name == "hybrid_rt" or name.endswith(".hybrid_rt")]
if not names:
    raise RuntimeError("Hybrid RT timing merge failed: the Hybrid RT extension is not enabled on this worker "
                       "(docs/FARM.md)")
merge = importlib.import_module(names[0] + ".hybrid_engine.reports.timing_merge")
charts = importlib.import_module(names[0] + ".blender_adapter.chart_images")
for path in merge.merge_folder(HYBRID_RT_MERGE["folder"], HYBRID_RT_MERGE["prefix"],
                               frames=HYBRID_RT_MERGE["frames"], chart_writer=charts.write_chart).values():
    print("Hybrid RT timing report written:", path)
`;

// Python source that binds NAME to VALUE (strings and numbers only: JSON is then valid Python).
function pythonWith(name, value, body) {
    return `${name} = ${JSON.stringify(value)}\n${body}`;
}

function compileJob(job) {
    print("Hybrid RT Render job submitted");
    print("job: ", job);

    const settings = job.settings;
    if (settings.engine && settings.engine != ENGINE_ID) {
        throw `The scene renders with ${settings.engine}, not Hybrid RT: choose Hybrid RT as the render engine, ` +
              `or submit it with another job type`;
    }
    if (["FFMPEG", "AVI_RAW", "AVI_JPEG"].indexOf(settings.format) >= 0) {
        throw `This job type renders image files, not "${settings.format}"`;
    }

    const renderOutput = renderOutputPath(job);
    // The job shows the output it actually used.
    settings.render_output_path = renderOutput;
    const renderDir = path.dirname(renderOutput);

    const renderTasks = authorRenderTasks(settings, renderDir, renderOutput);
    for (const task of renderTasks) {
        job.addTask(task);
    }
    if (settings.timing_reports) {
        const mergeTask = authorMergeTask(settings, renderDir);
        for (const task of renderTasks) {
            mergeTask.addDependency(task);
        }
        job.addTask(mergeTask);
    }
}

// Replaces {timestamp} in the output path by the job's creation time.
function renderOutputPath(job) {
    const output = job.settings.render_output_path;
    if (!output) {
        throw "no render_output_path setting!";
    }
    return output.replace(/{([^}]+)}/g, (match, name) => name == "timestamp" ? formatTimestampLocal(job.created) : match);
}

// The contiguous ranges of a chunk in Flamenco's notation ("1-4", "7", "3,5-8") as [first, last].
function chunkRanges(chunk) {
    return `${chunk}`.split(",").map((part) => part.trim()).filter((part) => part).map((part) => {
        const match = /^(-?\d+)(?:-(-?\d+))?$/.exec(part);
        if (!match) {
            throw `Cannot read the frames "${chunk}"`;
        }
        const first = parseInt(match[1], 10);
        return [first, match[2] === undefined ? first : parseInt(match[2], 10)];
    });
}

function authorRenderTasks(settings, renderDir, renderOutput) {
    print("authorRenderTasks(", renderDir, renderOutput, ")");
    const timingDir = path.join(renderDir, TIMING_CHUNKS_DIR);
    const tasks = [];
    for (const chunk of frameChunker(settings.frames, settings.chunk_size)) {
        const task = author.Task(`render-${chunk}`, "blender");
        const args = [
            // The check runs after the file is loaded (it follows the file name) and before the
            // frames; an exception in it ends Blender with exit code 1, failing the task.
            "--python-exit-code", "1",
            "--python-expr", ENGINE_CHECK_PY,
            "--render-output", path.join(renderDir, path.basename(renderOutput)),
            "--render-format", settings.format,
            "--render-frame", `${chunk}`.replaceAll("-", ".."), // Blender's frame range notation
        ];
        if (settings.timing_reports) {
            const ranges = chunkRanges(chunk).map(([first, last]) =>
                [first, last, path.join(timingDir, `${TIMING_PREFIX}_${first}-${last}`)]);
            args.push("--python-expr", pythonWith("HYBRID_RT_TIMING", { folder: timingDir, ranges: ranges }, TIMING_PY));
        }
        task.addCommand(author.Command("blender-render", {
            exe: "{blender}",
            exeArgs: "{blenderArgs}",
            argsBefore: [],
            blendfile: settings.blendfile,
            args: args,
        }));
        tasks.push(task);
    }
    return tasks;
}

function authorMergeTask(settings, renderDir) {
    const task = author.Task("merge-timing-reports", "blender");
    const merge = {
        folder: path.join(renderDir, TIMING_CHUNKS_DIR),
        prefix: path.join(renderDir, TIMING_PREFIX),
        frames: `${settings.frames}`,
    };
    task.addCommand(author.Command("blender-render", {
        exe: "{blender}",
        exeArgs: "{blenderArgs}",
        argsBefore: [],
        blendfile: "", // no file: the merge only reads the chunks' reports
        args: ["--python-exit-code", "1", "--python-expr", pythonWith("HYBRID_RT_MERGE", merge, MERGE_PY)],
    }));
    return task;
}
