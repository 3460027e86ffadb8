from physval.cli import main

raise SystemExit(main())
