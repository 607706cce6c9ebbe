"""teach.py with both the teach-in and the judged scenes restricted to cells facing the camera (surface
tilt cosine >= FACING from the heightmap):

    python docs/experiments_s7/teach2.py tuning BINS Q AREA FACING   # e.g. tuning 16 0.002 30 0.9
"""
import sys
FACING = float(sys.argv.pop(5)) if len(sys.argv) > 5 else 0.0
src = open("docs/experiments_s7/teach.py").read()
src = src.replace("import calibrate_attention as ca", """import calibrate_attention as ca
def facing(h):
    s = cv2.GaussianBlur(h.astype(np.float32), (0, 0), 1.0)
    gx = cv2.Sobel(s, cv2.CV_32F, 1, 0, ksize=3) / 0.016
    gy = cv2.Sobel(s, cv2.CV_32F, 0, 1, ksize=3) / 0.016
    return (h > 0.01) & (1 / np.sqrt(1 + gx**2 + gy**2) >= FACING)""")
src = src.replace("obj = t.height > 0.01", "obj = facing(t.height)").replace("o = r.height > 0.01", "o = facing(r.height)")
exec(src)
