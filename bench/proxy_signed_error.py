#!/usr/bin/python3
"""Where a proxy mesh is wrong: its signed distance to the synthetic truth,
split by which way the truth surface faces (up: n_z > 0.7, down: n_z < -0.7,
sides). Lab tool behind docs/notes/relight-fidelity-2026-11-27.md; needs the
Debian packages python3-numpy and python3-scipy (not installed by tools/).

Usage: bench/proxy_signed_error.py S/truth/meshes/OBJECT.obj MESH_OR_PLY [...]
  e.g. demo/capture/truth/meshes/spot.obj demo/workspace/reconstruct/proxy.obj
       demo/workspace/reconstruct/proxy_points/poisson.ply

Per candidate (an OBJ or PLY mesh, or a PLY point cloud such as
fused_points.ply), 200,000 area-uniform samples each way:
  t->c  truth sample to the nearest candidate sample, signed along the truth
        normal (+ = the candidate lies outside the truth surface);
  c->t  candidate sample to the nearest truth sample, signed the same way.
Read c->t for how far a candidate sits in or out: on a lumpy candidate the
nearest sample to a truth point is the bump that reaches closest, so the
t->c signed median understates the offset (a geometry-pass Poisson
surface: t->c -0.01 mm on the top, c->t -1.13 mm).
Nearest samples, not exact point-triangle distances: about 0.1 mm of
sampling noise at 200k samples on a 20 cm object.
"""
import sys
try:
    import numpy as np
    from scipy.spatial import cKDTree
except ImportError:
    sys.exit("proxy_signed_error.py needs numpy and scipy: apt-get install python3-numpy python3-scipy")

def read_obj(p):
    V, F = [], []
    for line in open(p):
        if line.startswith('v '):
            V.append([float(x) for x in line.split()[1:4]])
        elif line.startswith('f '):
            idx = [int(t.split('/')[0]) for t in line.split()[1:]]
            for k in range(1, len(idx) - 1):
                F.append([idx[0], idx[k], idx[k + 1]])
    V = np.array(V); F = np.array(F) - 1
    return V, F

def read_ply(p):
    with open(p, 'rb') as f:
        header = []
        while True:
            l = f.readline().decode('ascii').strip(); header.append(l)
            if l == 'end_header': break
        fmt = [l for l in header if l.startswith('format')][0].split()[1]
        nv = nf = 0; props = []; cur = None; face_types = None
        for l in header:
            t = l.split()
            if t[0] == 'element':
                cur = t[1]
                if cur == 'vertex': nv = int(t[2])
                if cur == 'face': nf = int(t[2])
            elif t[0] == 'property' and cur == 'vertex':
                props.append((t[2], t[1]))
            elif t[0] == 'property' and cur == 'face':
                face_types = (t[2], t[3])
        tmap = {'float': 'f4', 'float32': 'f4', 'double': 'f8', 'uchar': 'u1', 'uint8': 'u1', 'int': 'i4', 'int32': 'i4', 'uint': 'u4', 'uint32':'u4'}
        if fmt == 'ascii':
            data = np.loadtxt(f, max_rows=nv)
            names = [n for n, _ in props]
            V = data[:, [names.index('x'), names.index('y'), names.index('z')]]
            rest = f.read().decode().split('\n')
            F = np.array([[int(x) for x in r.split()[1:4]] for r in rest if r.strip()][:nf]) if nf else np.zeros((0, 3), int)
            return V, F
        dt = np.dtype([(n, '<' + tmap[t]) for n, t in props])
        arr = np.frombuffer(f.read(nv * dt.itemsize), dtype=dt)
        V = np.stack([arr['x'], arr['y'], arr['z']], 1).astype(float)
        F = np.zeros((0, 3), int)
        if nf:
            ct, it = tmap[face_types[0]], tmap[face_types[1]]
            rec = np.dtype([('n', '<' + ct), ('i', '<' + it, (3,))])
            F = np.frombuffer(f.read(nf * rec.itemsize), dtype=rec)['i'].astype(int)
        return V, F

def load(p):
    return read_obj(p) if p.endswith('.obj') else read_ply(p)

def sample(V, F, n, rng):
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    cr = np.cross(b - a, c - a); area = np.linalg.norm(cr, axis=1)
    nrm = cr / np.maximum(area[:, None], 1e-20)
    idx = rng.choice(len(F), n, p=area / area.sum())
    r1 = np.sqrt(rng.random(n)); r2 = rng.random(n)
    P = (1 - r1)[:, None] * a[idx] + (r1 * (1 - r2))[:, None] * b[idx] + (r1 * r2)[:, None] * c[idx]
    return P, nrm[idx]

rng = np.random.default_rng(0)
TV, TF = load(sys.argv[1])
TP, TN = sample(TV, TF, 200000, rng)
ttree = cKDTree(TP)
for cand in sys.argv[2:]:
    V, F = load(cand)
    if len(F):
        CP, CN = sample(V, F, 200000, rng)
    else:
        CP = V
    ctree = cKDTree(CP)
    # truth -> cand (signed along truth normal, + = cand outside)
    d, j = ctree.query(TP)
    s = np.einsum('ij,ij->i', CP[j] - TP, TN)
    # cand -> truth
    d2, k = ttree.query(CP)
    s2 = np.einsum('ij,ij->i', CP - TP[k], TN[k])
    nz = TN[:, 2]; nz2 = TN[k, 2]
    print(f"== {cand}: {len(CP)} pts; chamfer sym mean {(d.mean()+d2.mean())/2*1000:.2f} mm (t->c {d.mean()*1000:.2f}, c->t {d2.mean()*1000:.2f})")
    for name, m, m2 in [("up", nz > 0.7, nz2 > 0.7), ("down", nz < -0.7, nz2 < -0.7), ("side", abs(nz) <= 0.7, abs(nz2) <= 0.7)]:
        print(f"  {name:5s} share {m.mean():.2f}  t->c |e| {d[m].mean()*1000:5.2f} signed med {np.median(s[m])*1000:+5.2f} mean {s[m].mean()*1000:+5.2f} | c->t |e| {d2[m2].mean()*1000:5.2f} signed med {np.median(s2[m2])*1000:+5.2f}")
