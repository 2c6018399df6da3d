from cplus.cli import main

raise SystemExit(main())
