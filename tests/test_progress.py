"""The progress bar: silent off a terminal, few redraws on one, always its final state."""
import io

from vismobile.progress import Progress


class Terminal(io.StringIO):
    def isatty(self):
        return True


def test_redirected_stream_gets_nothing():
    stream = io.StringIO()
    bar = Progress("compare", stream=stream, total=500)
    for _ in range(500):
        bar.step()
    bar.close()
    assert stream.getvalue() == ""


def test_terminal_gets_few_redraws_and_the_end():
    stream = Terminal()
    bar = Progress("compare", stream=stream, total=500)
    for _ in range(500):
        bar.step()
    bar.close()
    draws = stream.getvalue().split("\r")[1:]
    assert 1 <= len(draws) <= 3 and "100%" in draws[-1] and stream.getvalue().endswith("\n")


def test_disabled_bar_never_draws_even_on_a_terminal():
    stream = Terminal()
    bar = Progress("octree", stream=stream, enabled=False)
    bar(1, 2)
    bar(2, 2)
    bar.close()
    assert stream.getvalue() == ""
