from helixd.cli import main

main()
