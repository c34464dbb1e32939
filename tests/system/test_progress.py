"""Slow stages say what they do on a terminal, and nothing anywhere else."""
import io
import time

from derive.progress import Stage


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
