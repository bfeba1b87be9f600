"""collect_warnings keeps a run's warning lines once each, from its own threads only."""
import logging
import threading

from rangeproc.run_warnings import collect_warnings


def test_lines_kept_once_and_only_from_the_run():
    log = logging.getLogger("rangeproc.some.module")
    with collect_warnings() as lines:
        log.warning("R1.csv: azimuth looks like radians")
        log.warning("R1.csv: azimuth looks like radians")
        log.info("not a warning")
        other = threading.Thread(target=lambda: log.warning("another sortie"), name="other")
        other.start()
        other.join()
        pool = threading.Thread(target=lambda: log.warning("from a worker"), name="rangeproc_0")
        pool.start()
        pool.join()
    log.warning("after the run")
    assert lines == ["R1.csv: azimuth looks like radians", "from a worker"]
