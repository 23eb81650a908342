import sys

from carlaverse.cli import main

sys.exit(main())
