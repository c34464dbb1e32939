"""Slow stages say what they do on a terminal, and nothing anywhere else."""
import io
import time

from derive.progress import Progress, Stage


def test_a_stage_draws_its_status_after_the_quiet_time_and_erases_it():
    out = io.StringIO()
    with Stage("derive", stream=out, enabled=True, quiet_for=0.05) as stage:
        stage.set("planar (1/5)")
        time.sleep(0.3)
    text = out.getvalue()
    assert "\rderive planar (1/5) 0 s" in text
    assert text.endswith("\r")                      # the line is cleared at the end


def test_a_short_stage_and_a_non_terminal_draw_nothing():
    out = io.StringIO()
    with Stage("derive", stream=out, enabled=True, quiet_for=5):
        pass
    with Stage("derive", stream=out) as stage:      # StringIO is no terminal
        stage.set("x")
        time.sleep(0.05)
    assert out.getvalue() == ""


def test_the_bar_estimates_the_time_left_once_a_part_is_done(monkeypatch):
    """done/total, the elapsed time, and from the first done part on the time left at the
    mean rate so far; nothing to estimate before that, nothing left at the end."""
    import derive.progress as progress
    clock = [100.0]
    monkeypatch.setattr(progress.time, "perf_counter", lambda: clock[0])
    out = io.StringIO()
    bar = progress.Progress("sweeping", 10, stream=out, force=True)
    first = out.getvalue()
    assert "0/10" in first and "left" not in first          # no part done: no estimate
    clock[0] += 4.0
    bar.update(2)                                           # 2 s per part, 8 parts to go
    drawn = out.getvalue()[len(first):]
    assert drawn.startswith("\r") and "2/10" in drawn and "4.0 s" in drawn
    assert drawn.rstrip().endswith("~16 s left"), drawn
    clock[0] += 146.0
    bar.update(5)                                           # 30 s per part, 5 to go: 150 s
    assert out.getvalue().rstrip().endswith("~2 min 30 s left"), out.getvalue()
    clock[0] += 1.0
    bar.update(10)
    last = out.getvalue().rsplit("\r", 1)[1]
    assert "10/10" in last and "left" not in last
    bar.close()


def test_the_estimate_follows_the_rate_of_a_real_clock():
    out = io.StringIO()
    bar = Progress("integrating", 4, stream=out, force=True)
    time.sleep(0.3)
    bar.update(1)
    left = float(out.getvalue().rsplit("~", 1)[1].split(" s left")[0])
    assert 1 <= left <= 3                                   # ~0.9 s of 3 parts at 0.3 s, at least 1 s
