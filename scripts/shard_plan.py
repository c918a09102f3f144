#!/usr/bin/python3
"""Splits a GoogleTest binary's tests into shards of about equal time, for scripts/gtest_shards.sh.

Usage: BINARY --gtest_list_tests [filter] | scripts/shard_plan.py COST_FILE SHARDS
Prints SHARDS lines, each the ':'-joined full names of one shard's tests (a --gtest_filter).

The costs are ctest's (Testing/Temporary/CTestCostData.txt: "name runs seconds" per line, up to a
"---" line), measured by the Release run of the same suite earlier in CI. A test suite stays in one
shard (a suite that prepares its scene once, in SetUpTestSuite, would prepare it in each shard it
is split over); suites are dealt out longest first, each to the shard with the least time so far.
GoogleTest's own sharding (GTEST_SHARD_INDEX) deals tests out by position instead: on CI's
sanitizer stage its two shards took 445 s and 257 s (2026-11-29), the long stitch and find tests
falling into one. ctest names a parameterised test by its parameter ("Angles/S.T/("bracket", 10)"),
GoogleTest by its index ("Angles/S.T/0"): such a test costs the mean of its instances; a test
missing from the file, the median of all.
"""
import statistics
import sys


def read_costs(path):
    costs = {}
    with open(path) as f:
        for line in f:
            if line.startswith("---"):
                break
            name, _, rest = line.rstrip("\n").partition(" ")
            try:
                costs[name] = float(rest.split()[-1])
            except (ValueError, IndexError):
                continue
    by_stem = {}
    for name, cost in costs.items():
        stem = name.split("/(")[0]
        by_stem.setdefault(stem, []).append(cost)
    return costs, {k: sum(v) / len(v) for k, v in by_stem.items()}


def listed_tests(lines):
    """Full test names from --gtest_list_tests output, in order."""
    suite, names = None, []
    for line in lines:
        if not line.strip() or line.startswith("Running main()"):
            continue
        if not line.startswith(" "):
            suite = line.split("#")[0].strip()
        elif suite:
            names.append(suite + line.split("#")[0].strip())
    return names


def main():
    if len(sys.argv) != 3 or int(sys.argv[2]) < 1:
        sys.exit("usage: BINARY --gtest_list_tests | shard_plan.py COST_FILE SHARDS")
    costs, stems = read_costs(sys.argv[1])
    shards = int(sys.argv[2])
    default = statistics.median(costs.values()) if costs else 1.0
    suites = {}
    for name in listed_tests(sys.stdin):
        stem = name.rsplit("/", 1)[0] if name.rsplit("/", 1)[-1].isdigit() else name
        cost = costs.get(name, stems.get(stem, default))
        suite = suites.setdefault(name.split(".")[0], [0.0, []])
        suite[0] += cost
        suite[1].append(name)
    plan = [[0.0, []] for _ in range(shards)]
    for cost, names in sorted(suites.values(), key=lambda s: -s[0]):
        least = min(plan, key=lambda p: p[0])
        least[0] += cost
        least[1].extend(names)
    for cost, names in plan:
        print(":".join(names))
        print(f"shard plan: {len(names)} tests, {cost:.0f} s in Release", file=sys.stderr)


if __name__ == "__main__":
    main()
