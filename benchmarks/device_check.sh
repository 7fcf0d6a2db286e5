#!/bin/bash
# SPDX-License-Identifier: GPL-3.0-or-later
# One short check on a lent GPU machine (docs/BENCHMARKS.md "GPU figures"): the figures the
# issues hold to a bar first, then the tests whose shaders llvmpipe forgives and a GPU may not.
#
#   bash benchmarks/device_check.sh OUT_DIR [SECONDS]
#
# Each step has its own time limit within SECONDS (default 480) and writes its report into
# OUT_DIR as it goes, so that a run cut short still returns what it finished: picture_cost
# --light, the frame section and the row passes' cost as JSON, the tests (verbose, so that
# a cut run still says which passed) with the failing comparisons' images (tests/_failures),
# picture_cost --light without the diffuse light's extras and with the gather's two
# shapes, and node_cost last
# (its four renderers' compiles take minutes on NVIDIA). The logs end up in one archive,
# logs.tar.gz: a lent machine returns only a handful of files. Needs numpy, moderngl,
# glcontext, flip_evaluator (the tests' FLIP: without it those tests fail as if their images
# differed) and pytest with xdist (no Blender: the tests that need it are not in the list).
set -o pipefail
out=${1:?usage: device_check.sh OUT_DIR [SECONDS]}
budget=${2:-480}
mkdir -p "$out"
start=$(date +%s)
left() { echo $(( budget - ($(date +%s) - start) )); }
step() {  # step NAME SHARE_OF_WHAT_IS_LEFT_IN_PERCENT COMMAND...
    local name=$1 share=$2
    shift 2
    local limit=$(( $(left) * share / 100 ))
    if [ "$limit" -lt 20 ]; then echo "== $name: skipped, ${limit} s left"; return; fi
    echo "== $name (limit ${limit} s)"
    timeout "$limit" "$@" > "$out/$name.log" 2>&1
    echo "   rc $? after $(( $(date +%s) - start )) s"
}
export PYTHONUNBUFFERED=1 __GL_SHADER_DISK_CACHE=0 MESA_SHADER_CACHE_DISABLE=true
python3 -c "from hybrid_engine.gpu import gl_context as g; print(g.renderer_name())" || exit 1
python3 -c "import flip_evaluator" || { echo "flip_evaluator is missing: install its wheel first"; exit 1; }
git rev-parse --short HEAD 2>/dev/null

step picture_light 40 python3 -m benchmarks.picture_cost --light --rounds 3 --json "$out/picture_light.json"
tail -4 "$out/picture_light.log" 2>/dev/null
step frame 30 python3 -m benchmarks.bench --sections frame --variants auto --json "$out/frame.json"
tail -16 "$out/frame.log" 2>/dev/null
# The passes that read the G-buffer's rows (moved surfaces, Cryptomatte, Vector) per frame.
step row_passes 15 python3 -m benchmarks.row_passes_cost --detail 1 --size 1280x720 --json "$out/row_passes.json"
tail -4 "$out/row_passes.log" 2>/dev/null
# The diffuse paths' radiance cache on a still view (the frame section's moving pieces leave it idle).
step radiance_cache 15 python3 -m benchmarks.radiance_cache_cost --detail 1 --size 1280x720 --json "$out/radiance_cache.json"
tail -4 "$out/radiance_cache.log" 2>/dev/null
step tests 50 python3 -m pytest -rf -v -n 16 -p no:cacheprovider \
    tests/test_cube_light.py tests/test_diffuse_light.py tests/test_radiance_cache.py tests/test_radiance_cache_cost.py \
    tests/test_emitter_light.py \
    tests/test_node_light_path.py tests/test_cube_march.py tests/test_node_codegen.py tests/test_denoise.py \
    tests/test_emitter_links.py tests/test_grazing_triangles.py tests/test_surface_motion.py \
    tests/test_cube_map.py tests/test_instance_transform.py tests/test_gbuffer.py tests/test_row_passes_cost.py \
    tests/test_vector_pass.py::test_a_deforming_mesh_moves_with_its_vertices_not_its_matrix \
    tests/test_vector_pass.py::test_a_box_with_alpha_moves_its_pixels_as_often_as_the_g_buffer_sees_it \
    tests/test_cryptomatte.py::test_a_card_of_alpha_0_3_gives_seven_tenths_of_its_coverage_to_the_floor_it_shows \
    -k "not renders_as_cycles"  # those two need bpy, which the device lacks
grep -cE " PASSED" "$out/tests.log" 2>/dev/null | sed "s/^/   passed so far: /"
grep -E "^FAILED| FAILED|passed|failed" "$out/tests.log" 2>/dev/null | tail -20
[ -d tests/_failures ] && tar -czf "$out/failures.tar.gz" -C tests _failures
# The same with the diffuse light's two costliest extras switched off (the grazing triangles'
# whole-ray test and the extra paths of a short history): what they cost on this GPU.
step picture_light_plain 40 python3 -c "
import sys
from hybrid_engine.passes.diffuse_light import diffuse_light
diffuse_light.BVH_WHOLE_RAY = False
diffuse_light.SHORT_HISTORY_PATHS = 1
from benchmarks import picture_cost
picture_cost.main(['--light', '--rounds', '3', '--json', sys.argv[1]])
" "$out/picture_light_plain.json"
tail -4 "$out/picture_light_plain.log" 2>/dev/null
# The diffuse gather's two shapes side by side in one process (persistent invocations, the
# GPU's; one pixel per invocation, llvmpipe's), alternating call by call.
step gather_shapes 40 python3 -c "
import sys, json
from hybrid_engine.gpu import variants
from benchmarks import picture_cost
out = {}
for k, shape in enumerate(['gpu', 'cpu', 'gpu', 'cpu']):
    variants.set_override('gather=' + shape)
    r = out[f'{k}_{shape}'] = picture_cost.measure(rounds=2, light=True)
    print(shape, 'on', r['on']['median_ms'], 'shade', r['on']['passes'].get('shade'), 'off', r['off']['median_ms'],
          'ratio', r['ratio_median'], r['ratio_mean'], flush=True)
    json.dump(out, open(sys.argv[1], 'w'), indent=1)
" "$out/gather_shapes.json"
tail -4 "$out/gather_shapes.log" 2>/dev/null
step node_cost 100 python3 -m benchmarks.node_cost --rounds 3 --size 640x360 --json "$out/node_cost.json"
tail -12 "$out/node_cost.log" 2>/dev/null
# One archive of the logs: a lent machine returns a handful of files.
tar -czf "$out/logs.tar.gz" -C "$out" $(cd "$out" && ls *.log) && rm -f "$out"/*.log
