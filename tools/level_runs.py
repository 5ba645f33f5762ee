"""A capsule case run at several grid levels, each with its own membrane resolution: the
shared part of the validations against published values (tools/tube_sphere.py,
tools/constriction_park.py). Not a script."""
import subprocess
import sys


def add_arguments(parser, tolerance):
    """CAPSFLOW CASE OUT, the levels with one node count each, the pass tolerance and the
    extra --set overrides."""
    parser.add_argument("capsflow")
    parser.add_argument("case")
    parser.add_argument("out")
    parser.add_argument("--levels", default="5,6")
    parser.add_argument("--nodes", default="642,2562")
    parser.add_argument("--tolerance", type=float, default=tolerance)
    parser.add_argument("--set", action="append", default=[])


def levels_and_nodes(args, tool):
    """The (adapt.max_level, capsule nodes) pairs of --levels and --nodes."""
    levels = [int(x) for x in args.levels.split(",")]
    nodes = [int(x) for x in args.nodes.split(",")]
    if len(nodes) != len(levels):
        sys.exit(f"{tool}: --nodes needs one count per level of --levels")
    return list(zip(levels, nodes))


def run(args, level, nodes, out, overrides=()):
    """capsflow run CASE into out at adapt.max_level = level with that many membrane nodes,
    then the tool's overrides and the user's --set ones (the last word)."""
    cmd = [args.capsflow, "run", args.case, "--out", out, "--force", "--quiet",
           "--set", f"adapt.max_level={level}", "--set", f"capsule[0].nodes={nodes}"]
    for s in list(overrides) + args.set:
        cmd += ["--set", s]
    subprocess.run(cmd, check=True)
