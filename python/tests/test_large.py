"""10^6 poses pass through without a copy per pose: the readings are read from the numpy
array's memory (no numpy-side conversion) and copied once, in one block, into the core's flat
pose storage; results come back as arrays made from the core's vectors."""

from __future__ import annotations

import subprocess
import sys
import textwrap
import tracemalloc

import numpy as np
import pytest

import lincal
from conftest import MODELS, REPO

N = 1_000_000


def on_the_line(n: int, seed: int = 0) -> np.ndarray:
    """n poses of the AdeptOne (a1 = 0.375, a2 = 0.425, th2 = 0.0446) whose tips lie on the
    line b = (-1.79, -0.56), in closed form: tip = e^{i q1} w, w = a1 + a2 e^{i(q2 - th2)}."""
    a1, a2, th2, b1, b2 = 0.375, 0.425, 0.0446, -1.79, -0.56
    rng = np.random.default_rng(seed)
    q2 = rng.uniform(-2.5, 2.5, size=4 * n)
    wx, wy = a1 + a2 * np.cos(q2 - th2), a2 * np.sin(q2 - th2)
    c = -1.0 / (np.hypot(b1, b2) * np.hypot(wx, wy))
    ok = np.abs(c) < 0.999
    q2, wx, wy, c = q2[ok][:n], wx[ok][:n], wy[ok][:n], c[ok][:n]
    q1 = np.arccos(c) - np.arctan2(wy, wx) + np.arctan2(b2, b1)
    q1 = np.angle(np.exp(1j * q1))
    q = np.empty((n, 2))
    q[:, 0], q[:, 1] = q1, q2
    return q


@pytest.fixture(scope="module")
def big():
    q = on_the_line(N)
    assert q.shape == (N, 2)
    return q


@pytest.fixture(scope="module")
def spec():
    return lincal.Spec.from_yaml(MODELS / "adept_one.yaml")


def test_a_million_poses_calibrate_without_a_numpy_copy(spec, big):
    tracemalloc.start()
    try:
        cal = lincal.calibrate(spec, big)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    # numpy's allocations are traced: a conversion of q would be 16 MB here.
    assert peak < 1 << 20, peak
    assert cal.poses == N
    assert cal.residuals.shape == (N,)
    v = cal.values
    assert v["a2"] / v["a1"] == pytest.approx(0.425 / 0.375, abs=1e-9)
    assert v["th2"] == pytest.approx(0.0446, abs=1e-9)
    assert cal.residual_rms < 1e-9


def test_a_conversion_is_visible_so_the_check_above_means_something(spec, big):
    q32 = big[:100_000].astype(np.float32)
    tracemalloc.start()
    try:
        lincal.calibrate(spec, q32)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak >= 100_000 * 2 * 8  # the float64 copy numpy made


def test_tip_and_residuals_of_a_million_poses(spec, big):
    tracemalloc.start()
    try:
        tips = spec.tip(big)
        r = spec.residuals(big, [0.375, 0.0, 0.425, 0.0446, -1.79, -0.56])
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 1 << 20, peak  # outputs come from Rust vectors, untraced, never copied
    assert tips.shape == (N, 2) and tips.flags.c_contiguous and tips.flags.owndata is False
    assert not np.shares_memory(tips, big)
    assert r.shape == (N,) and float(r.max()) < 1e-9


def test_peak_memory_of_a_million_poses_is_a_few_bytes_a_pose():
    """In a fresh interpreter: the peak resident memory calibrate adds above the array it is
    given. One flat copy of q is 16 B a pose, the constraint index and the residuals 8 B each;
    a copy per pose (a vector each) would add 56 B or more a pose on its own."""
    code = textwrap.dedent(
        f"""
        import resource, sys
        sys.path.insert(0, {str(__import__('pathlib').Path(__file__).parent)!r})
        import numpy as np, lincal
        from test_large import on_the_line
        spec = lincal.Spec.from_yaml({str(MODELS / 'adept_one.yaml')!r})
        lincal.calibrate(spec, on_the_line(2000, 1))   # warm up: threads, code pages
        q = on_the_line({N})
        import gc; gc.collect()
        def status(key):
            with open("/proc/self/status") as f:
                for line in f:
                    if line.startswith(key + ":"):
                        return int(line.split()[1]) * 1024
        try:
            with open("/proc/self/clear_refs", "w") as f:
                f.write("5")  # resets the peak (VmHWM) to the current resident size
        except OSError:
            print("skip")
            raise SystemExit(0)
        base = status("VmRSS")
        cal = lincal.calibrate(spec, q)
        print(status("VmHWM") - base)
        """
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    if out.stdout.split()[-1] == "skip":
        pytest.skip("no /proc/self/clear_refs to reset the peak resident size")
    added = int(out.stdout.split()[-1])
    print(f"calibrate of {N} poses: peak +{added / 2**20:.1f} MiB, {added / N:.1f} B a pose")
    # Measured: 40 B a pose (q 16, constraint index 8, residuals 8, the outlier pass 8).
    assert added < 80 * N, f"{added / N:.1f} bytes a pose"


def test_a_broadcast_view_beyond_memory_is_a_memory_error_before_any_copy(spec):
    # 10^10 rows cost the caller 16 bytes; lincal would need terabytes.
    q = np.broadcast_to(np.array([[0.1, 0.2]]), (10**10, 2))
    with pytest.raises(MemoryError, match="10000000000 poses"):
        lincal.calibrate(spec, q)


def test_a_simulation_beyond_memory_is_a_memory_error_before_any_allocation(spec):
    # 10^12 poses would take 40 TB: refused with the estimate, at once.
    with pytest.raises(MemoryError, match="1000000000000 poses"):
        lincal.simulate(spec, 10**12)
    # Under an address-space limit too (a subprocess, to keep the limit there).
    script = textwrap.dedent(
        f"""
        import resource, lincal
        resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))
        spec = lincal.Spec.from_yaml({str(MODELS / "adept_one.yaml")!r})
        try:
            lincal.simulate(spec, 10**9)
        except MemoryError as e:
            print("MemoryError", e)
        """
    )
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("MemoryError"), out.stdout + out.stderr


def test_under_an_address_space_limit_a_big_view_is_a_memory_error():
    # The attack's case: 10^8 rows under a 4 GB limit (a subprocess, to keep the limit there).
    script = textwrap.dedent(
        f"""
        import resource, numpy as np, lincal
        resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))
        spec = lincal.Spec.from_yaml({str(MODELS / "adept_one.yaml")!r})
        q = np.broadcast_to(np.array([[0.1, 0.2]]), (10**8, 2))
        try:
            lincal.calibrate(spec, q)
        except MemoryError as e:
            print("MemoryError", e)
        """
    )
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("MemoryError"), out.stdout + out.stderr


def test_ctrl_c_interrupts_a_running_fit_and_the_next_call_runs(spec):
    script = textwrap.dedent(
        f"""
        import os, signal, sys, threading, time
        sys.path.insert(0, {str(MODELS.parent.parent / "python" / "tests")!r})
        from test_large import on_the_line
        import lincal
        spec = lincal.Spec.from_yaml({str(MODELS / "adept_one.yaml")!r})
        q = on_the_line(2_000_000)
        threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGINT)).start()
        try:
            lincal.calibrate(spec, q, refine=True, start="nominal")
            print("finished")
        except KeyboardInterrupt:
            print("interrupted")
        cal = lincal.calibrate(spec, q[:1000])
        print("then", cal.poses)
        """
    )
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["interrupted", "then", "1000"], out.stdout + out.stderr


def test_a_nine_joint_arm_with_every_parameter_unknown_has_its_basis_at_the_defaults():
    """Issue 48: no expansion bound refuses a 9-joint arm with every DH parameter unknown (the
    CLI's `basis` takes it too): the basis is every joint monomial, 3^9."""
    spec = lincal.Spec.from_yaml(REPO / "tests" / "large" / "arm9_all_unknown_point.yaml")
    b = spec.basis()
    assert b.basis_size == 3**9
    assert b.identifiable_count == 35


def test_urdf_native_rows_of_a_seven_joint_arm_have_their_basis_at_the_defaults():
    """Issue 48, build item 5: `Spec.from_yaml` takes URDF-native rows of a 7-joint arm (six
    unknowns a joint; the direct expansion would pass the bound): every joint monomial, 3^7,
    the full grid proven stage by stage, with c(p) left in factored form."""
    spec = lincal.Spec.from_yaml(REPO / "tests" / "large" / "iiwa14_urdf_native.yaml")
    b = spec.basis()
    assert b.basis_size == 3**7
    assert b.identifiable_count == 31
    assert any("full grid" in w for w in b.to_dict()["warnings"])


def test_grid_bases_beyond_the_expansion_have_their_basis_at_the_defaults():
    """Issue 48, build item 5: `Spec.from_yaml` takes what the CLI takes where the direct
    expansion would pass its bound by orders of magnitude: a 6-joint arm on an unknown
    quadric (5^6), URDF-native rows of 9 joints on a point (3^9), every parameter unknown, and
    the 6-joint arm on a quadric with a diagonal `A` (9 861 of the 5^6 products arise)."""
    for name, k, identifiable in [
        ("arm6_all_unknown_quadric", 5**6, 29),
        ("urdf9_all_unknown_point", 3**9, 35),
        ("arm6_diagonal_quadric", 9861, 27),
        ("arm7_cylinder", 17083, 28),
    ]:
        b = lincal.Spec.from_yaml(REPO / "tests" / "large" / f"{name}.yaml").basis()
        assert b.basis_size == k, name
        assert b.identifiable_count == identifiable, name
