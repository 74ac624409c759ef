"""``playerstage`` (the console script) and ``python -m playerstage``: subcommands.

``playerstage sweep PLAN.toml ...`` runs a parameter sweep (``playerstage sweep --help``).
"""

import sys
from typing import List, Optional

COMMANDS = {"sweep": "run a parameter sweep of a Stage world (playerstage sweep --help)"}


def main(argv: Optional[List[str]] = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help"):
        print("usage: playerstage COMMAND ...\n\ncommands:")
        for name, what in COMMANDS.items():
            print(f"  {name:8} {what}")
        return 0 if argv else 2
    command, rest = argv[0], argv[1:]
    if command == "sweep":
        from .sweep.cli import main as sweep

        return sweep(rest)
    print(f"playerstage: unknown command `{command}` (commands: {', '.join(COMMANDS)})",
          file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
