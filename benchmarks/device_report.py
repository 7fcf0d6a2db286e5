# SPDX-License-Identifier: GPL-3.0-or-later
"""The benchmark's device report (``python -m benchmarks.bench --device-report PATH``): a
Markdown page about the GL device the bench ran on, ready to paste into the "GPU figures"
section of docs/BENCHMARKS.md -- what the driver is, the limits the passes size themselves
by (gpu/gl_context.py GLLimits), which kernel variants it chose (gpu/variants.py), and the
measured sections with the targets a hardware GPU is held to."""
from __future__ import annotations

from hybrid_engine.gpu import gl_context

# GL queries reported besides gl_context.limits() (moderngl's context info keys).
EXTRA_LIMITS = ("GL_MAX_VIEWPORTS", "GL_MAX_UNIFORM_BLOCK_SIZE", "GL_MAX_SHADER_STORAGE_BUFFER_BINDINGS",
                "GL_MAX_COMPUTE_SHARED_MEMORY_SIZE", "GL_MAX_RENDERBUFFER_SIZE")


def gl_description() -> dict:
    """The renderer, vendor and version strings and the limits of the shared context."""
    ctx = gl_context.get_context()
    info = ctx.info
    limits = gl_context.limits()
    values = {
        "max SSBO block size (bytes)": limits.max_ssbo_block_bytes,
        "max compute workgroup count": "x".join(str(v) for v in limits.max_compute_workgroup_count),
        "max compute workgroup size": "x".join(str(v) for v in limits.max_compute_workgroup_size),
        "max compute invocations per workgroup": limits.max_compute_invocations,
        "max texture size": limits.max_texture_size,
        "max 3D texture size": limits.max_3d_texture_size,
        "max array texture layers": limits.max_array_texture_layers,
        "max compute storage blocks": limits.max_compute_storage_blocks,
    }
    for key in EXTRA_LIMITS:
        if key in info:
            value = info[key]
            values[key] = "x".join(str(v) for v in value) if isinstance(value, tuple) else value
    return {"renderer": str(info.get("GL_RENDERER", "unknown")), "vendor": str(info.get("GL_VENDOR", "unknown")),
            "version": str(info.get("GL_VERSION", "unknown")), "limits": values}


def _number(value, digits: int = 2) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:,.{digits}f}"
    return f"{value:,}" if isinstance(value, int) else str(value)


def section_rows(report: dict) -> list[tuple[str, str, str, str]]:
    """(section, measurement, value, target) per measured figure of ``report``."""
    rows: list[tuple[str, str, str, str]] = []
    target = report.get("lbvh_target")
    if target:
        rows.append(("lbvh_target", f"LBVH build, {target['triangles']:,} triangles (ms)",
                     _number(target["build_ms"], 3),
                     f"<= {target['target_ms']:g} ms: {'met' if target['met'] else 'not met'}"))
    target = report.get("frame_target")
    if target:
        rows.append(("frame_target", f"Chess HYBRID {target['resolution']}, max depth {target['max_depth']}, "
                     f"median of {target['frames']} frames (FPS)", _number(target["fps"]),
                     f">= {target['target_fps']:g} FPS: {'met' if target['met'] else 'not met'}"))
    for row in report.get("lbvh", []):
        rows.append(("lbvh", f"LBVH build, {row['triangles']:,} triangles (ms); Embree build",
                     f"{_number(row['build_ms'])}; {_number(row.get('embree_build_ms'))}", ""))
    trace = report.get("trace")
    if trace:
        rows.append(("trace", f"reflection rays, {trace['rays']:,} rays, {trace['triangles']:,} triangles "
                     "(Mrays/s); Embree", f"{_number(trace['mrays_per_s'], 3)}; "
                     f"{_number(trace.get('embree_mrays_per_s'), 3)}", ""))
    frame = report.get("frame")
    if frame:
        rows.append(("frame", f"Chess {frame['resolution']}: HYBRID / FULL_BVH (ms), speedup",
                     f"{_number(frame['hybrid_ms'], 1)} / {_number(frame['full_bvh_ms'], 1)}, "
                     f"{_number(frame['speedup'])}", ""))
    return rows


def kernel_rows(kernels: dict) -> list[str]:
    """The kernel section's Markdown table: each metric of each kernel in each family."""
    families = sorted({family for per_kernel in kernels.get("kernels", {}).values() for family in per_kernel})
    if not families:
        return ["No kernel has two shapes in the code yet."]
    ratio = "gpu / cpu" if set(families) == {"gpu", "cpu"} else None
    header = ["kernel", "measurement", *families] + ([ratio] if ratio else [])
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for kernel, per_family in kernels["kernels"].items():
        metrics = next(iter(per_family.values())).keys()
        for metric in metrics:
            cells = [_number(per_family.get(family, {}).get(metric), 3) for family in families]
            if ratio:
                gpu, cpu = per_family["gpu"][metric], per_family["cpu"][metric]
                cells.append(f"{gpu / cpu:.2f}" if cpu else "-")
            lines.append(f"| {kernel} | {metric} | " + " | ".join(cells) + " |")
    return lines


def _kernels_in_code() -> tuple[str, ...]:
    from .kernel_bench import kernels_in_code

    return kernels_in_code()


def device_report(report: dict, command: str) -> str:
    """The Markdown page for ``report`` (bench.run's), produced by ``command``."""
    gl = report.get("device") or gl_description()
    chosen = report.get("variants", {})
    # The kernels section lists them when it ran; any report may ask the code itself.
    in_code = set(report.get("kernels", {}).get("in_code", [])) or set(_kernels_in_code())
    lines = [f"### {gl['renderer']}", "",
             f"Produced by `{command}`{' (quick sizes: not figures to publish)' if report.get('quick') else ''}.", "",
             "| GL | |", "|---|---|",
             f"| renderer | {gl['renderer']} |", f"| vendor | {gl['vendor']} |", f"| version | {gl['version']} |"]
    lines += [f"| {name} | {_number(value)} |" for name, value in gl["limits"].items()]
    lines += ["", "Kernel variants chosen for this renderer (gpu/variants.py):", "",
              "| kernel | chosen | two shapes in the code |", "|---|---|---|"]
    lines += [f"| {kernel} | {family} | {'yes' if kernel in in_code else 'not yet'} |"
              for kernel, family in chosen.items()]
    lines += ["", "Measured sections (medians):", "", "| section | measurement | value | target |",
              "|---|---|---|---|"]
    lines += [f"| {section} | {what} | {value} | {target} |" for section, what, value, target in section_rows(report)]
    if "kernels" in report:
        lines += ["", f"Kernel variants side by side ({report['kernels']['mode']}):", ""]
        lines += kernel_rows(report["kernels"])
    return "\n".join(lines) + "\n"
