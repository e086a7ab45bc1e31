"""The benchmark's floor (``vibroimpact bench``): the bare Rust loop it times against ours
runs the same case with the same scheme (its histories equal ours to Newton's tolerance; a
wrong law, clearance or step would differ by millimetres). No timing is asserted."""

from vibroimpact.benchmarks.sdof import floor_benchmark


def test_floor_runs_the_same_steps_as_ours() -> None:
    row = floor_benchmark(repeats=1)
    assert row["steps"] == 20_000
    assert row["max_displacement_difference_m"] < 1e-9
    assert row["ours_s"] > 0 and row["floor_s"] > 0
