import sys

try:                        # Ctrl-C while the imports run (seconds on a busy machine): one line too
    from .cli import main
except KeyboardInterrupt:
    print("derive: interrupted", file=sys.stderr)
    sys.exit(130)

sys.exit(main())
