from fsci.cli import main

raise SystemExit(main())
