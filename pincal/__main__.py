import sys

from pincal.cli import main

sys.exit(main())
