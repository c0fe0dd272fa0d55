"""Compares two cargo unit graphs (--unit-graph JSON): prints each non-workspace unit of the
second (the wheel's build) that the first (the workspace test build) lacks, same package, target,
mode, features and profile (the profile's name aside: cargo does not hash it). Exit 1 if any.
Used by tools/wheel-pins.sh."""
import json,sys
def load(f):
    g=json.load(open(f)); s={}
    for u in g["units"]:
        if u["mode"] not in ("build","run-custom-build"): continue
        pid=u["pkg_id"].split("#")[-1] if "#" in u["pkg_id"] else u["pkg_id"]
        key=(u["pkg_id"].split("/")[-1].split("#")[-1], u["target"]["name"], u["mode"], tuple(sorted(u["features"])), json.dumps({k:v for k,v in u["profile"].items() if k!="name"},sort_keys=True))
        s[key]=u
    return s
ws=load(sys.argv[1]); py=load(sys.argv[2])
n=0
for k in sorted(py):
    if "robosim" in k[0] or "robosim" in py[k]["pkg_id"]: continue
    if k not in ws:
        n+=1
        # find same pkg/target in ws
        alts=[w for w in ws if w[0]==k[0] and w[1]==k[1] and w[2]==k[2]]
        print(k[0],k[1],k[2],"py feats",k[3], "| ws feats", [a[3] for a in alts], "| same feats diff profile" if any(a[3]==k[3] for a in alts) else "")
print("wheel units not in the workspace build:", n, "of", len(py))
sys.exit(1 if n else 0)
