#!/usr/bin/env python3
"""`omnisim describe` against OpenCV, scikit-image and numpy: time per image per descriptor,
on the same images, in one run (issue 18).

Images (rendered once into --work by `omnisim render`, env1-textured): a 512² pinhole (90°
field of view, looking at the brick wall and the chequered rug), the same view at 1024² (SIFT
at twice the scale), a 512² equirectangular image and the paper's 250² omni image; the omni
image's 512 × 128 panorama comes from `omnisim project` (8-bit, for the peers; `describe`
resamples its own in f32 from the same model).

Each image is rendered COPIES times (the same pose). Each round runs `omnisim describe` once
per image folder with every descriptor (each descriptor's time per image is the `seconds` its
sidecar records for each frame: the descriptor alone, not the image's reading nor the
panorama's resampling; the first frame is left out), then the peers on the same image, each
called COPIES times and timed around its one call, the first call left out as omnisim's first
frame is (reading and converting the image left out). Each side's time covers the same work:
the Fourier signature's, for instance, is omnisim's `FourierSignature::new` (rows of the f32
panorama to f64, a real FFT — realfft's even-length transform with only the 16 kept bins
unpacked) with the magnitudes and phases as
f32, against `np.fft.rfft` of the f64 panorama with `np.abs` and `np.angle` of the first 16.

| omnisim            | peer                                                              |
|--------------------|-------------------------------------------------------------------|
| sift               | `cv2.SIFT_create().detectAndCompute` (8-bit grey, as OpenCV reads) |
| surf               | `cv2.xfeatures2d.SURF_create(100)` where the build has it (the pip |
|                    | wheels leave the non-free module out: then no peer)               |
| block-hog          | `skimage.feature.hog`: 9 bins, 8 × 8 cells, 2 × 2 blocks, L2-Hys   |
| hog (panorama)     | `skimage.feature.hog`: 8 bins, 16 cells of the full width, 1 × 1   |
|                    | blocks, L2 (the same 16 × 8 histogram)                             |
| fourier (panorama) | `np.fft.rfft` of each row, first 16 coefficients, magnitude, phase |
| radon              | `skimage.transform.radon` over 360 angles, `circle=True`           |
| gist               | none (LMgist's own code is MATLAB)                                 |
| panorama (omni)    | `cv2.remap`, `INTER_CUBIC`, of the f32 grey image to 512 × 128     |

The omni image's descriptors that read the panorama are given one resampled by describe
(bicubic, through a table of each pixel's taps made once per run), and each frame's resampling
is timed apart (`panorama_seconds` in the sidecar's frames; a --baseline build from before
2026-11-27 records only the mean over all frames, which its cell then shows for every frame):
the row "panorama" is that time,
against `cv2.remap` with the same view's maps (Mei's model from the render's
calibration-opencv-omnidir.yaml, made once, not timed). The peers' panorama for their Fourier
signature and HOG is `omnisim project`'s (8-bit), so the signature rows time the transform
alone on both sides; what a user of describe pays per omni frame for the signature is the
panorama row plus the signature row.

Threads: `RAYON_NUM_THREADS` for omnisim and `cv2.setNumThreads` for OpenCV are both set to
--threads; scikit-image and numpy run these on one thread.

Prints one JSON line per (image, descriptor) on stderr and a Markdown table: best (and
median) of all timed calls in ms (two decimals under 1 ms), the ratio peer / omnisim (above 1: omnisim is faster) and the load average.

--baseline BIN times a second omnisim build (an earlier commit's) in the same rounds.

--images and --descriptors keep only those (comma-separated slugs such as omni-250 and names such
as sift): `--images omni-250 --descriptors sift --copies 40` times omni SIFT alone, 39 calls a
round each, and the median over rounds of peer median / omnisim median is printed too.

Usage: descriptors.py --omnisim target/release/omnisim --work /tmp/descriptors [--baseline OLD_BIN] [--rounds 5] [--threads 1]
       [--images omni-250,...] [--descriptors sift,...] [--copies 4]
Needs OpenCV, numpy and scikit-image (tests/readers/requirements.txt).
"""
import argparse, json, os, shutil, statistics, subprocess, sys, time

import cv2
import numpy as np
import skimage
from skimage.feature import hog as skimage_hog
from skimage.transform import radon as skimage_radon

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENE = os.path.join(ROOT, 'scenes', 'env1-textured.ron')
VIEW = '1.0 0.5 0.4 0 20 200'
PAPER_POSE = '1.5 0 0.4 0 0 60'
# Each image is rendered this many times (the same pose) and described in one process; the
# first is left out of the times (a process's first image also pays for rayon's threads and
# fresh memory: 10–30 ms), and each peer is called as often in one process.
COPIES = 4

# name: (render options, descriptors omnisim runs on it)
IMAGES = {
    'pinhole 512²': (['--camera', 'pinhole', '--size', '512x512', '--hfov', '90'], VIEW,
                     ['sift', 'surf', 'block-hog', 'radon']),
    'pinhole 1024²': (['--camera', 'pinhole', '--size', '1024x1024', '--hfov', '90'], VIEW, ['sift', 'surf']),
    'equirect 512²': (['--camera', 'equirect', '--size', '512x512'], PAPER_POSE,
                      ['sift', 'surf', 'fourier', 'hog', 'gist']),
    'omni 250²': (['--camera', 'omni', '--size', '250x250'], PAPER_POSE,
                  ['sift', 'surf', 'radon', 'fourier', 'hog', 'gist']),
}
PANORAMA = (512, 128)  # describe's default for omni images
ELEVATION = (-45.0, 15.0)  # describe's default band, degrees
# Descriptors that read the panorama (describe resamples the omni image once for all of them).
READS_PANORAMA = ('fourier', 'hog', 'gist')


def slug(name):
    return name.replace(' ', '-').replace('²', '')


def folder(work, name):
    return os.path.join(work, slug(name))


def render(omnisim, work):
    for name, (options, pose, _) in IMAGES.items():
        out = folder(work, name)
        if not os.path.exists(os.path.join(out, 'render.json')):
            poses = os.path.join(work, f'{slug(name)}-poses.txt')
            with open(poses, 'w') as f:
                f.write(f'{pose}\n' * COPIES)
            subprocess.run([omnisim, 'render', SCENE, *options, '--poses-file', poses, '--out', out, '--overwrite'],
                           check=True, capture_output=True)
    omni = folder(work, 'omni 250²')
    pano = os.path.join(work, 'omni-panorama')
    if not os.path.isdir(pano):
        w, h = PANORAMA
        subprocess.run([omnisim, 'project', omni, '--view', f'panorama:width={w},height={h}', '--out', pano],
                       check=True, capture_output=True)


def png(directory, suffix=''):
    for root, _, files in os.walk(directory):
        for f in sorted(files):
            if f.endswith(suffix + '.png') and (suffix or f[-8:-4].isdigit()):
                return os.path.join(root, f)
    sys.exit(f'no image in {directory}')


def describe(omnisim, work, name, threads):
    """Seconds per image of each descriptor (all images but the first), from describe's sidecars."""
    out = os.path.join(work, 'describe', slug(name))
    if os.path.isdir(out):
        shutil.rmtree(out)
    args = [omnisim, 'describe', folder(work, name), '--out', out]
    for d in IMAGES[name][2]:
        if d != 'panorama':
            args += ['-d', d]
    env = dict(os.environ, RAYON_NUM_THREADS=str(threads))
    subprocess.run(args, check=True, capture_output=True, env=env)
    (set_folder,) = [os.path.join(out, s) for s in os.listdir(out)]
    sidecars = {d: json.load(open(os.path.join(set_folder, d + '.json'))) for d in IMAGES[name][2] if d != 'panorama'}
    seconds = {d: [f['seconds'] for f in sidecar['frames'][1:]] for d, sidecar in sidecars.items()}
    if 'panorama' in IMAGES[name][2]:
        # Each frame's resampling, recorded beside any descriptor that reads the panorama;
        # builds before 2026-11-27 record only the mean over all frames (the first included),
        # which then stands for every frame.
        sidecar = next(sidecars[d] for d in READS_PANORAMA if d in sidecars)
        frames = sidecar['frames'][1:]
        seconds['panorama'] = ([f['panorama_seconds'] for f in frames] if 'panorama_seconds' in frames[0]
                               else [sidecar['panorama_seconds_per_image']] * len(frames))
    return seconds


def timed(call):
    """Seconds of each of COPIES calls but the first (cold, like omnisim's first frame)."""
    seconds = []
    for _ in range(COPIES):
        start = time.perf_counter()
        call()
        seconds.append(time.perf_counter() - start)
    return seconds[1:]


def panorama_maps(work):
    """cv2.remap's maps for describe's panorama of the omni image: column u at azimuth
    π − 2π(u + ½)/W, row v at tan(elevation) = (cy − v)/fy (the band's edges at the rows' outer
    edges), projected by Mei's unified model from the render's OpenCV omnidir calibration."""
    calibration = cv2.FileStorage(os.path.join(folder(work, 'omni 250²'), 'calibration-opencv-omnidir.yaml'),
                                  cv2.FILE_STORAGE_READ)
    k, xi = calibration.getNode('camera_matrix').mat(), calibration.getNode('xi').real()
    # The model below reads fx, fy, cx, cy and xi only: it holds for this render's camera (no
    # skew, no distortion, the mirror frame the body's), which a change of render options
    # could break without a word.
    if (k[0, 1] != 0 or np.any(calibration.getNode('distortion_coefficients').mat() != 0)
            or not np.array_equal(calibration.getNode('body_from_mirror').mat(), np.eye(3))):
        sys.exit('panorama_maps: the omni render has skew, distortion or a turned mirror; '
                 'the peer\'s maps model none of these')
    (w, h), (low, high) = PANORAMA, np.radians(ELEVATION)
    fy = h / (np.tan(high) - np.tan(low))
    cy = fy * np.tan(high) - 0.5
    azimuth = np.pi - 2 * np.pi * (np.arange(w) + 0.5) / w
    x, y = np.broadcast_to(np.cos(azimuth), (h, w)), np.broadcast_to(np.sin(azimuth), (h, w))
    z = np.broadcast_to(((cy - np.arange(h)) / fy)[:, None], (h, w))
    # The model's camera frame is the mirror frame with z reversed (the calibration's notes).
    denominator = -z + xi * np.sqrt(x * x + y * y + z * z)
    map_x = (k[0, 0] * x / denominator + k[0, 2]).astype(np.float32)
    map_y = (k[1, 1] * y / denominator + k[1, 2]).astype(np.float32)
    return map_x, map_y


def peers(work, name, wanted):
    """Seconds of each peer of a `wanted` descriptor on this image (None: no peer)."""
    grey8 = cv2.imread(png(folder(work, name)), cv2.IMREAD_GRAYSCALE)
    grey = grey8.astype(np.float64) / 255.0
    if name == 'omni 250²':
        pano = cv2.imread(png(os.path.join(work, 'omni-panorama'), '-panorama'), cv2.IMREAD_GRAYSCALE) / 255.0
    else:
        pano = grey
    sift = cv2.SIFT_create()

    def surf():
        try:
            surf = cv2.xfeatures2d.SURF_create(100)
        except (AttributeError, cv2.error):
            return None
        return timed(lambda: surf.detectAndCompute(grey8, None))
    rows = pano.shape[0] // 16

    def fourier():
        # rfft: the real-input transform a numpy user would call on an image (2× np.fft.fft's speed).
        spectrum = np.fft.rfft(pano, axis=1)[:, :16]
        return np.abs(spectrum), np.angle(spectrum)
    angles = np.arange(360, dtype=np.float64)
    calls = {
        'sift': lambda: timed(lambda: sift.detectAndCompute(grey8, None)),
        'surf': surf,
        'block-hog': lambda: timed(lambda: skimage_hog(grey, orientations=9, pixels_per_cell=(8, 8),
                                                       cells_per_block=(2, 2), block_norm='L2-Hys')),
        'hog': lambda: timed(lambda: skimage_hog(pano, orientations=8, pixels_per_cell=(rows, pano.shape[1]),
                                                 cells_per_block=(1, 1), block_norm='L2')),
        'fourier': lambda: timed(fourier),
        'radon': lambda: timed(lambda: skimage_radon(grey, theta=angles, circle=True)),
        'gist': lambda: None,
    }
    if 'panorama' in wanted:
        map_x, map_y = panorama_maps(work)
        grey32 = grey.astype(np.float32)
        calls['panorama'] = lambda: timed(lambda: cv2.remap(grey32, map_x, map_y, cv2.INTER_CUBIC,
                                                            borderMode=cv2.BORDER_REPLICATE))
    return {d: calls[d]() for d in wanted}


def main():
    global COPIES
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--omnisim', required=True)
    parser.add_argument('--work', required=True)
    parser.add_argument('--rounds', type=int, default=5)
    parser.add_argument('--threads', type=int, default=1)
    parser.add_argument('--baseline', help='another omnisim binary, timed in the same rounds')
    parser.add_argument('--images', help='comma-separated image slugs to keep (omni-250, pinhole-512, ...)')
    parser.add_argument('--descriptors', help='comma-separated descriptors to keep (sift, hog, ...)')
    parser.add_argument('--copies', type=int, default=COPIES, help='renders of each image, calls per round')
    args = parser.parse_args()
    if args.copies < 2:
        parser.error('--copies must be at least 2: the first (cold) call of each round is not timed')
    COPIES = args.copies
    for name in list(IMAGES):
        options, pose, descriptors = IMAGES.pop(name)
        kept = [d for d in descriptors if not args.descriptors or d in args.descriptors.split(',')]
        if name == 'omni 250²' and any(d in READS_PANORAMA for d in kept):
            kept.append('panorama')
        if kept and (not args.images or slug(name) in args.images.split(',')):
            IMAGES[name] = (options, pose, kept)
    os.makedirs(args.work, exist_ok=True)
    cv2.setNumThreads(args.threads)
    render(args.omnisim, args.work)
    times = {}  # (image, descriptor) -> {'omnisim': [...], 'baseline': [...], 'peer': [...]}
    loads = []
    round_ratios = {}  # (image, descriptor) -> per round, peer median / omnisim median
    for _ in range(args.rounds):
        loads.append(os.getloadavg()[0])
        for name, (_, _, descriptors) in IMAGES.items():
            baseline = describe(args.baseline, args.work, name, args.threads) if args.baseline else {}
            ours = describe(args.omnisim, args.work, name, args.threads)
            theirs = peers(args.work, name, descriptors)
            for d in descriptors:
                if theirs[d] and ours[d]:
                    ratio = statistics.median(theirs[d]) / statistics.median(ours[d])
                    round_ratios.setdefault((name, d), []).append(ratio)
                entry = times.setdefault((name, d), {'omnisim': [], 'baseline': [], 'peer': []})
                entry['omnisim'] += ours[d]
                entry['baseline'] += baseline.get(d, [])
                entry['peer'] += theirs[d] or []
    peer_names = {'sift': f'OpenCV {cv2.__version__}', 'surf': 'OpenCV (non-free)', 'block-hog': 'scikit-image',
                  'hog': 'scikit-image', 'radon': 'scikit-image', 'fourier': f'numpy {np.__version__}', 'gist': '—',
                  'panorama': f'OpenCV {cv2.__version__} remap'}
    print(f'# {args.rounds} rounds, {args.threads} thread(s), load average {min(loads):.1f}–{max(loads):.1f}, '
          f'scikit-image {skimage.__version__}')
    print('| image | descriptor | baseline ms | omnisim ms | peer | peer ms | peer / omnisim |')
    print('|---|---|---:|---:|---|---:|---:|')

    def cell(seconds):
        ms = [1e3 * t for t in seconds]
        digits = 2 if min(ms, default=0) < 1 else 1
        return f'{min(ms):.{digits}f} ({statistics.median(ms):.{digits}f})' if ms else '—'
    for (name, d), entry in times.items():
        row = {'image': name, 'descriptor': d, 'threads': args.threads,
               **{f'{k}_ms': [round(1e3 * t, 2) for t in v] for k, v in entry.items()}}
        print(json.dumps(row, ensure_ascii=False), file=sys.stderr)
        theirs = entry['peer']
        ratio = f'{min(theirs) / min(entry["omnisim"]):.2f}×' if theirs and entry['omnisim'] else ''
        print(f'| {name} | {d} | {cell(entry["baseline"])} | {cell(entry["omnisim"])} | '
              f'{peer_names[d] if theirs else "none"} | {cell(theirs)} | {ratio} |')
    for (name, d), ratios in round_ratios.items():
        print(f'# {name} {d}: peer / omnisim by round (medians) {" ".join(f"{r:.2f}" for r in ratios)}; '
              f'median {statistics.median(ratios):.2f}×')


if __name__ == '__main__':
    main()
