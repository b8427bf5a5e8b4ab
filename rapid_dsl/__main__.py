import sys

from rapid_dsl.cli import main

sys.exit(main())
