"""The argument check of the wrapper commands calibrate_sim, sim_fleet and odometry_sim.

    code=$(/usr/bin/python3 launch_args.py COMMAND FILE.launch "$@") || exit
    eval "$code"

Reads the <arg>s FILE.launch declares (launch/ beside this script's folder, else
`rospack find autocal`/launch) and checks every argument: only NAME:=VALUE with NAME one of them is
accepted (an <arg> with a fixed value= is not settable). A bad argument: the message names it,
suggests the nearest valid name and lists them all; exit 64. -h or --help: prints shell code that
prints the usage with the valid arguments and exits 0. Otherwise prints `set -- ARGS` (shell-quoted)
with every path argument absolute: relative to the current directory ($PWD; the nodes run in
$ROS_HOME), ~ expanded, each element of a comma-separated list (robot_configs); an empty value
or a $(...) substitution is left as given.
"""
import difflib
import os
import shlex
import subprocess
import sys
import xml.etree.ElementTree as ET

# The path-valued <arg>s of the wrappers' launch files (one path each) and the comma-separated
# lists of paths. test/scripts/test_wrappers.py checks that every path-like <arg> is here.
PATH_ARGS = {"calibration_root", "robot_config", "world_config", "bag", "bag_file", "errors_file",
             "intrinsics_file", "result_file", "config"}
PATH_LIST_ARGS = {"robot_configs"}
USAGE_EXIT = 64  # the exit-code table's bad command line (sysexits EX_USAGE)


def launch_path(name):
    here = os.path.dirname(os.path.realpath(__file__))
    path = os.path.join(here, os.pardir, "launch", name)
    if os.path.isfile(path):
        return os.path.normpath(path)
    try:
        pkg = subprocess.run(["rospack", "find", "autocal"], capture_output=True, text=True,
                             check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        pkg = ""
    return os.path.join(pkg, "launch", name) if pkg else os.path.normpath(path)


def declared_args(path):
    """The <arg>s of the launch file itself (not those it passes to its <include>s): the settable
    ones in order, (name, default or None, doc), and the names of those with a fixed value=."""
    settable, fixed = [], set()

    def walk(element):
        for child in element:
            if child.tag == "arg" and "name" in child.attrib:
                if "value" in child.attrib:
                    fixed.add(child.get("name"))
                else:
                    settable.append((child.get("name"), child.get("default"), child.get("doc", "")))
            elif child.tag not in ("include", "node", "test"):
                walk(child)

    walk(ET.parse(path).getroot())
    return settable, fixed


def current_dir():
    pwd = os.environ.get("PWD", "")
    try:
        if os.path.isabs(pwd) and os.path.samefile(pwd, "."):
            return pwd
    except OSError:
        pass
    return os.getcwd()


def absolute(value, cwd):
    if not value or value.startswith("$("):  # empty, or a roslaunch substitution: as given
        return value
    value = os.path.expanduser(value)
    return value if os.path.isabs(value) else os.path.normpath(os.path.join(cwd, value))


def resolve(name, value, cwd):
    if name in PATH_ARGS:
        return absolute(value, cwd)
    if name in PATH_LIST_ARGS and value:
        return ",".join(absolute(item.strip(), cwd) for item in value.split(","))
    return value


def usage(command, launch, args):
    width = max(len(name) for name, _, _ in args) if args else 0
    lines = ["usage: rosrun autocal %s [NAME:=VALUE ...]" % command,
             "runs roslaunch autocal %s NAME:=VALUE ...; relative paths are taken from" % launch,
             "the current directory. NAME is one of the launch file's arguments:"]
    for name, default, doc in args:
        text = "(required)" if default is None else "default: %s" % (default or '""')
        lines.append("  %-*s  %s%s" % (width, name, text, ("; " + doc) if doc else ""))
    return "\n".join(lines)


def main(argv):
    command, launch, given = argv[0], argv[1], argv[2:]
    path = launch_path(launch)
    try:
        args, fixed = declared_args(path)
    except (OSError, ET.ParseError) as exc:
        sys.stderr.write("%s: cannot read the arguments of %s: %s\n" % (command, path, exc))
        return USAGE_EXIT
    names = [name for name, _, _ in args]
    if any(arg in ("-h", "--help") for arg in given):
        print("printf '%%s\\n' %s; exit 0" % shlex.quote(usage(command, launch, args)))
        return 0
    cwd = current_dir()
    out, bad = [], []
    for arg in given:
        name, sep, value = arg.partition(":=")
        if sep and name in names:
            out.append("%s:=%s" % (name, resolve(name, value, cwd)))
            continue
        near = []
        if arg.startswith("-"):
            why = "is an option: only NAME:=VALUE arguments are accepted"
        elif not sep:  # NAME=VALUE, or a bare word
            name, eq, value = arg.partition("=")
            why = "is not NAME:=VALUE"
            near = [n + ":=" + (value if eq else "VALUE")
                    for n in difflib.get_close_matches(name, names, n=1)]
        elif name in fixed:
            why = "is set by %s itself, not settable" % launch
        else:
            why = "is not an argument of %s" % launch
            near = [n + ":=" + value for n in difflib.get_close_matches(name, names, n=1)]
        hint = ("; did you mean %s?" % shlex.quote(near[0])) if near else ""
        bad.append("%s: %s %s%s" % (command, shlex.quote(arg), why, hint))
    if bad:
        sys.stderr.write("\n".join(bad) + "\n%s: valid arguments (NAME:=VALUE): %s\n"
                         % (command, " ".join(names)))
        return USAGE_EXIT
    print("set -- " + " ".join(shlex.quote(arg) for arg in out))
    return 0


if __name__ == "__main__":
    if len(sys.argv) < 3:
        sys.stderr.write("usage: launch_args.py COMMAND FILE.launch [NAME:=VALUE ...]\n")
        sys.exit(USAGE_EXIT)
    sys.exit(main(sys.argv[1:]))
