# SPDX-License-Identifier: GPL-3.0-or-later
"""hybrid_engine.reports.timing_merge: a farm job's chunk reports become one report, frames in
order and the summary recomputed over all of them."""
from __future__ import annotations

import json

import pytest

from hybrid_engine.reports import timing_merge
from hybrid_engine.reports.timing_report import FrameRecord, TimingReport, TimingReportError, summarize, write_json


def chunk(frames: list[int], machine: str = "worker-a", renderer: str = "NVIDIA RTX A6000") -> TimingReport:
    """A chunk's report with distinct, fixed times per frame (no GL needed)."""
    records = [FrameRecord(frame=f, total_ms=10.0 + 3.0 * f, passes={"shade": 2.0 + f, "trace": 8.0 + 2.0 * f},
                           counts={"triangles_total": 1000 + f, "triangles_bvh": 10 * f},
                           mode="HYBRID", timing_source="wall clock", near_size=None if f % 2 else 5.0 + f)
               for f in frames]
    return TimingReport(records=records, requested_mode="HYBRID", settings={"mode": "HYBRID"}, target_fps=30.0,
                        scene={"name": "Shot"}, machine={"node": machine}, gl_renderer=renderer, warmup_frames=1)


def test_a_written_report_reads_back_into_the_same_report(tmp_path):
    report = chunk([3, 4, 5])
    write_json(report, tmp_path / "a.json")
    again = timing_merge.load_report(tmp_path / "a.json")
    assert again.to_dict() == json.loads((tmp_path / "a.json").read_text())


def test_two_chunks_merge_into_frames_in_order_with_the_summary_over_all_frames():
    late, early = chunk([5, 6]), chunk([1, 2, 3, 4])
    merged = timing_merge.merge_reports([late, early])
    assert [record.frame for record in merged.records] == [1, 2, 3, 4, 5, 6]
    assert merged.summary() == summarize(early.records + late.records, 30.0)
    assert merged.summary()["frame_ms"]["mean"] == pytest.approx(10.0 + 3.0 * 3.5)
    assert merged.warnings == [] and merged.machine == {"node": "worker-a"}


def test_chunks_from_several_workers_name_every_machine_and_warn():
    merged = timing_merge.merge_reports([chunk([1], "worker-a"), chunk([2], "worker-b", "llvmpipe")])
    assert merged.machine == {"machines": [{"node": "worker-a"}, {"node": "worker-b"}]}
    assert merged.gl_renderer == "NVIDIA RTX A6000; llvmpipe"
    assert "2 machines with 2 GL renderers" in merged.warnings[0]


def test_a_frame_in_two_chunks_or_missing_from_every_chunk_is_an_error():
    with pytest.raises(TimingReportError, match=r"frames \[2\] appear in more than one"):
        timing_merge.merge_reports([chunk([1, 2]), chunk([2, 3])])
    with pytest.raises(TimingReportError, match=r"no chunk reported the frames \[3, 4\]"):
        timing_merge.merge_reports([chunk([1, 2]), chunk([5])], timing_merge.parse_frames("1-5"))


def test_flamencos_frame_notation_is_read():
    assert timing_merge.parse_frames("3, 5-7, 10..11") == [3, 5, 6, 7, 10, 11]
    with pytest.raises(TimingReportError, match="cannot read the frames"):
        timing_merge.parse_frames("1-x")


def test_a_file_that_is_not_a_report_is_named(tmp_path):
    (tmp_path / "b.json").write_text('{"frames": [{"frame": 1}]}')
    with pytest.raises(TimingReportError, match="b.json"):
        timing_merge.load_report(tmp_path / "b.json")
