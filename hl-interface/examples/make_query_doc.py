#!/usr/bin/env python3
"""Fills the examples section of docs/query.md with real answers.

Runs every request of hl-interface/examples/requests.jsonl through the query transport and
writes each request and its answer between the markers in docs/query.md. Answers longer than
LIMIT characters are cut, and the cut is marked. Usage, from the repository root:

    cargo build -p robosim-hl-interface --example query
    python3 hl-interface/examples/make_query_doc.py target/debug/examples/query
"""
import json
import subprocess
import sys

LIMIT = 900
BEGIN, END = "<!-- examples:begin -->", "<!-- examples:end -->"


def main():
    exe = sys.argv[1]
    reqs = open("hl-interface/examples/requests.jsonl").read().splitlines()
    out = subprocess.run([exe, "--input", "hl-interface/examples/requests.jsonl"],
                         capture_output=True, text=True, check=True).stdout.splitlines()
    assert len(out) == len(reqs), (len(out), len(reqs))
    parts = []
    for req, ans in zip(reqs, out):
        a = json.loads(ans)
        if a["ok"]:
            title = f"`{json.loads(req)['op']}`"
        else:
            title = f"error `{a['error']['kind']}`"
        parts.append(f"#### {title}\n")
        if len(ans) > LIMIT:
            ans = ans[:LIMIT] + f" …  [cut here: {len(ans) - LIMIT} more characters]"
        parts.append(f"```\n{req}\n{ans}\n```\n")
    doc = open("docs/query.md").read()
    head, rest = doc.split(BEGIN)
    _, tail = rest.split(END)
    open("docs/query.md", "w").write(head + BEGIN + "\n" + "\n".join(parts) + END + tail)


if __name__ == "__main__":
    main()
