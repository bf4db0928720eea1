from helixd.cli.app import main

main()
