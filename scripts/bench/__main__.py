import sys

try:
    import matplotlib  # noqa: F401  (the plots)
    import numpy  # noqa: F401  (EXR images, noise across seeds)
except ImportError as e:
    sys.exit("bench: error: %s; run the harness with Debian's /usr/bin/python3 (python3-numpy, python3-matplotlib)" % e)

from .cli import main  # noqa: E402

main()
