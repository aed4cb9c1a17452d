from vrsweep.cli import main

main()
