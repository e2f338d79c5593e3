from motionplc.cli import main

raise SystemExit(main())
