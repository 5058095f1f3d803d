from stereogest.cli import main

raise SystemExit(main())
