# scripts/formal.sh's helper: turns every $assert cell of a lowered RTLIL module into an output
# that is high when it fails (EN and not A), so one AIGER holds every property, output k the k-th
# line of the names file.
import re
import sys

source, target, names = sys.argv[1:4]
text, listed = open(source).read(), []


def output(match):
    name, a, en = match.group(1), match.group(2), match.group(3)
    listed.append(name.lstrip('\\'))
    k = len(listed)
    return (f'  wire output {k} \\formal_fails_{k}\n  wire \\formal_not_{k}\n'
            f'  cell $_NOT_ \\formal_not_cell_{k}\n    connect \\A {a}\n    connect \\Y \\formal_not_{k}\n  end\n'
            f'  cell $_AND_ \\formal_and_cell_{k}\n    connect \\A {en}\n    connect \\B \\formal_not_{k}\n'
            f'    connect \\Y \\formal_fails_{k}\n  end\n')


text = re.sub(r'  cell \$assert (\S+)\n    connect \\A (.+)\n    connect \\EN (.+)\n  end\n', output, text)
open(target, 'w').write(text)
open(names, 'w').write(''.join(name + '\n' for name in listed))
