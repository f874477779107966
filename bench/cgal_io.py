# Helper of bench/bench_flatten.sh: a disk region as OFF for bench/cgal_authalic.cpp, and its uv back
# as GIFTI on the full vertex indexing (unused vertices at 0,0), so `authalic metrics` and evalmap.py read it.
import sys, numpy as np, nibabel as nib
mode = sys.argv[1]
def load(f):
    g = nib.load(f); P = [a.data for a in g.darrays if a.intent == 1008][0]; T = [a.data for a in g.darrays if a.intent == 1009]
    return np.asarray(P, float), np.asarray(T[0], np.int64)
if mode == 'off':  # SURF FACES_SURF OUT.off OUT.idx
    P, _ = load(sys.argv[2]); _, T = load(sys.argv[3])
    used = np.unique(T); idx = -np.ones(len(P), np.int64); idx[used] = np.arange(len(used))
    with open(sys.argv[4], 'w') as f:
        f.write(f'OFF\n{len(used)} {len(T)} 0\n')
        np.savetxt(f, P[used], fmt='%.9g')
        np.savetxt(f, np.c_[np.full(len(T), 3), idx[T]], fmt='%d')
    np.save(sys.argv[5], used)
else:  # uv: SURF FACES_SURF UV.txt IDX.npy OUT.surf.gii
    P, _ = load(sys.argv[2]); _, T = load(sys.argv[3]); uv = np.loadtxt(sys.argv[4]); used = np.load(sys.argv[5])
    Q = np.zeros((len(P), 3), np.float32); Q[used, :2] = uv
    g = nib.gifti.GiftiImage(darrays=[nib.gifti.GiftiDataArray(Q, intent='NIFTI_INTENT_POINTSET', datatype='NIFTI_TYPE_FLOAT32'),
                                      nib.gifti.GiftiDataArray(T.astype(np.int32), intent='NIFTI_INTENT_TRIANGLE', datatype='NIFTI_TYPE_INT32')])
    nib.save(g, sys.argv[6])
