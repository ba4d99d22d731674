import sys

from ._inspect import main

sys.exit(main())
