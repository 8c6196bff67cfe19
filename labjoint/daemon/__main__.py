"""``python -m labjoint.daemon``: the daemon without the full CLI (systemd, tests).

``--output-off`` only switches the generator output OFF and exits (systemd's
ExecStopPost, so a crashed daemon never leaves the shakers driven).
Exit codes as the CLI: 2 bad input, 3 hardware, 1 other labjoint error.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Sequence

from labjoint.cli.daemon_glue import output_off, run_daemon
from labjoint.errors import HardwareError, InputError, LabjointError


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m labjoint.daemon", description=__doc__.splitlines()[0])
    p.add_argument("--config", default=None, help="rig config TOML (default: the simulated rig)")
    p.add_argument("--data-dir", default=None, help="run files (default: the config's rig.data_dir)")
    p.add_argument("--queue-db", default=None, help="job queue (default: <data_dir>/queue.sqlite)")
    p.add_argument("--poll-s", type=float, default=0.2, help="queue polling period (s)")
    p.add_argument("--output-off", action="store_true", help="switch the generator output OFF and exit")
    args = p.parse_args(argv)
    try:
        if args.output_off:
            print(json.dumps(output_off(args.config)))
            return 0
        return run_daemon(args.config, args.data_dir, queue_db=args.queue_db, poll_s=args.poll_s)
    except LabjointError as exc:
        code = 2 if isinstance(exc, InputError) else 3 if isinstance(exc, HardwareError) else 1
        sys.stderr.write(f"labjoint daemon: error: {exc}\n")
        return code


if __name__ == "__main__":
    sys.exit(main())
