"""Command lines of the measurement scripts: `--name value` options with defaults, -h / --help
printing the script's docstring, the rest positional; errors as one `haha: error:` line."""
import sys


def die(msg):
    sys.stderr.write('haha: error: %s\n' % msg)
    sys.exit(1)


def parse_args(argv, opts, doc):
    """Fills opts (option -> default) from argv and returns the positional arguments; prints
    doc and exits 0 on -h / --help."""
    pos = []
    i = 0
    while i < len(argv):
        if argv[i] in opts:
            if i + 1 >= len(argv):
                die('%s: needs a value' % argv[i])
            opts[argv[i]] = argv[i + 1]
            i += 2
        elif argv[i] in ('-h', '--help'):
            print(doc)
            sys.exit(0)
        else:
            pos.append(argv[i])
            i += 1
    return pos
