"""``make gpu-check`` (bench/gpu_check.py) runs on the CPU at its small sizes and writes every
field of ``gpu.json``, so the script cannot rot between the times a GPU is available."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from bench.gpu_check import BYTES_PER_CELL_STEP, known_bandwidth
from tests.paths import ROOT


def test_known_bandwidth_takes_the_most_specific_name() -> None:
    assert known_bandwidth("NVIDIA H100 80GB HBM3") == 3350.0
    assert known_bandwidth("NVIDIA H100 PCIe") == 2000.0
    assert known_bandwidth("NVIDIA H200") == 4800.0
    assert known_bandwidth("NVIDIA GH200 480GB") == 4000.0
    assert known_bandwidth("NVIDIA A100-SXM4-80GB") == 2039.0
    assert known_bandwidth("NVIDIA A100-SXM4-40GB") == 1555.0
    assert known_bandwidth("cpu") is None


@pytest.mark.slow
def test_small_run_on_cpu_writes_every_field(tmp_path: Path) -> None:
    out = tmp_path / "gpu.json"
    env = {**os.environ, "JAX_PLATFORMS": "cpu"}
    done = subprocess.run([sys.executable, "-m", "bench.gpu_check", "--small", "--out", str(out)],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    result = json.loads(out.read_text())
    assert result["small"] is True
    assert result["device"]["backend"] == "cpu"
    assert result["device"]["bandwidth_source"] == "measured copy"
    bandwidth = result["device"]["bandwidth_used_gbs"]
    assert bandwidth > 0
    assert result["checks"]["ok"] is True
    assert result["checks"]["mode_decay_euler"]["relative_error"] < 1e-4
    for size, row in result["gray_scott"].items():
        if size == "section_s":
            continue
        n = int(size.split("x")[0])
        assert row["steps_per_s"] > 0
        assert row["bandwidth_bound_steps_per_s"] == pytest.approx(
            bandwidth * 1e9 / (BYTES_PER_CELL_STEP * n * n))
        assert row["share_of_bound"] == pytest.approx(
            row["steps_per_s"] / row["bandwidth_bound_steps_per_s"])
    mesh = result["mesh"]
    assert mesh["vertices"] > 100
    assert mesh["stochastic"]["steps_per_s"] > 0 and mesh["deterministic"]["steps_per_s"] > 0
    assert result["neural"]["iterations_per_s"] > 0
    assert result["skaggs"]["valid"] >= 1 and result["skaggs"]["generation_s"] > 0
    assert result["networks"]["generation_s"] > 0
    assert "skipped" in result["tests"]
    assert result["machine"]["cpu_count"] == os.cpu_count()
    assert not list(tmp_path.glob("*.tmp*"))
