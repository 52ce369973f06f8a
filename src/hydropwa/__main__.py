from hydropwa.cli import main

main()
