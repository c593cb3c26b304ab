# Writes hall.obj and hall.mtl: a hall 75 m long, 12 m wide, 8 m tall whose two long walls
# each hold 75 lancets per row (`python3 hall.py ROWS`, 1 to 3 rows), glass in cut openings,
# coloured by MTL `Tf` as other tools write glass. The benchmark of docs/performance.md
# ("Many windows") cooks it with `cooker cook hall.obj -o hall.pack`.
import sys
L, W, H = 75.0, 12.0, 8.0
rows = [(1.5, 2.5), (3.5, 4.5), (5.5, 6.5)][: int(sys.argv[1])]
v = []; f = []
def quad(mtl, o, a, b):
    n = len(v)
    for p in (o, (o[0]+a[0], o[1]+a[1], o[2]+a[2]), (o[0]+a[0]+b[0], o[1]+a[1]+b[1], o[2]+a[2]+b[2]), (o[0]+b[0], o[1]+b[1], o[2]+b[2])):
        v.append(p)
    f.append((mtl, n+1, n+2, n+3, n+4))
quad("floor", (0,0,0), (0,0,W), (L,0,0))
quad("stone", (0,H,0), (L,0,0), (0,0,W))
quad("stone", (0,0,0), (0,H,0), (0,0,W))
quad("stone", (L,0,0), (0,0,W), (0,H,0))
cols = 75; pitch = L/cols; ww = 0.25
for side, z in (("n", 0.0), ("s", W)):
    ys = [0.0] + [y for r in rows for y in r] + [H]
    for k in range(0, len(ys), 2):
        quad("stone", (0, ys[k], z), (L, 0, 0), (0, ys[k+1]-ys[k], 0))
    for (y0, y1) in rows:
        xs = 0.0
        for c in range(cols):
            cx = pitch*(c+0.5)
            quad("stone", (xs, y0, z), (cx-ww/2-xs, 0, 0), (0, y1-y0, 0))
            quad(f"glass_{side}", (cx-ww/2, y0, z), (ww, 0, 0), (0, y1-y0, 0))
            xs = cx+ww/2
        quad("stone", (xs, y0, z), (L-xs, 0, 0), (0, y1-y0, 0))
with open("hall.mtl","w") as m:
    m.write("newmtl floor\nKd 0.6 0.6 0.6\nnewmtl stone\nKd 0.5 0.48 0.45\n")
    m.write("newmtl glass_n\nKd 0.2 0.3 0.8\nTf 0.2 0.3 0.8\nd 0.3\nnewmtl glass_s\nKd 0.8 0.2 0.2\nTf 0.8 0.2 0.2\nd 0.3\n")
with open("hall.obj","w") as o:
    o.write("mtllib hall.mtl\n")
    for p in v: o.write("v %g %g %g\n" % p)
    cur=None
    for (mtl,a,b,c,d) in f:
        if mtl!=cur: o.write(f"usemtl {mtl}\n"); cur=mtl
        o.write(f"f {a} {b} {c} {d}\n")
