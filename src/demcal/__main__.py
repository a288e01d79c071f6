import sys

from demcal.cli import main

sys.exit(main())
