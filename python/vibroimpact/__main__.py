import sys

from vibroimpact.cli import main

sys.exit(main())
