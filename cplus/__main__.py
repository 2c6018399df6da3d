from cplus.cli import run

run()
