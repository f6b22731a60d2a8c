#!/usr/bin/env bash
# Footage the project was not tuned on, made from the shared recordings: each variant changes what a new user's
# camera would change (mirror = the other driving side, crop and rescale = another lens and sensor, thinned frame
# rate, grayscale, heavy recompression) and is written as a plain video or image folder, so that a run sees
# nothing of the dataset's calibration, poses or annotations.
#
#   tools/make_variants.sh [SHARED_DIR] OUT_DIR
#
# SHARED_DIR defaults to $HAZARDFORGE_SHARED, else ../shared. Writes OUT_DIR/<variant>.mp4 or OUT_DIR/<variant>/
# (frames) and OUT_DIR/variants.txt (what each one is). configs/campaign_variants.yaml runs every kind on them.
set -euo pipefail

if [[ $# -eq 2 ]]; then
  shared=$1 out=$2
elif [[ $# -eq 1 ]]; then
  shared=${HAZARDFORGE_SHARED:-../shared} out=$1
else
  echo "usage: $0 [SHARED_DIR] OUT_DIR" >&2
  exit 2
fi
nus=$shared/data/nuscenes/samples/CAM_FRONT
kitti=$shared/data/kitti-raw-2011_09_26/2011_09_26/image_02/data
uda=$shared/data/udacity-highway/test_video.mp4
for p in "$nus" "$kitti" "$uda"; do
  [[ -e $p ]] || { echo "$0: $p: not found (is $shared the shared folder?)" >&2; exit 1; }
done
command -v ffmpeg >/dev/null || { echo "$0: ffmpeg is needed (apt-get install ffmpeg)" >&2; exit 1; }
mkdir -p "$out"
ff() { ffmpeg -hide_banner -loglevel error -y "$@"; }
list=$(mktemp -d)
trap 'rm -rf "$list"' EXIT

# nuScenes keyframes (2 Hz) in time order as an image sequence ffmpeg reads.
i=0
for f in $(ls "$nus" | sort); do
  ln -s "$(cd "$nus" && pwd)/$f" "$list/$(printf '%05d' $i).jpg"
  i=$((i + 1))
done

# 1. nuScenes mirrored (left-hand traffic becomes right-hand), a 2 fps MP4 at 960x540.
ff -framerate 2 -i "$list/%05d.jpg" -vf "hflip,scale=960:540" -c:v libx264 -crf 20 -pix_fmt yuv420p -r 2 \
  "$out/nuscenes_mirrored.mp4"
# 2. nuScenes cropped to its centre 1200x675 (a narrower lens) and rescaled to 640x360, recompressed hard.
ff -framerate 2 -i "$list/%05d.jpg" -vf "crop=1200:675:200:112,scale=640:360" -c:v libx264 -crf 32 \
  -pix_fmt yuv420p -r 2 "$out/nuscenes_crop_640.mp4"
# 3. KITTI raw thinned from 10 Hz to 5 Hz, grayscale, as an image folder (source.fps=5).
mkdir -p "$out/kitti_gray_5hz"
i=0
for f in $(ls "$kitti" | sort); do
  if (( i % 2 == 0 )); then
    ff -i "$kitti/$f" -vf format=gray "$out/kitti_gray_5hz/$(printf '%06d' $((i / 2))).png"
  fi
  i=$((i + 1))
done
# 4. KITTI raw mirrored and cropped at the sides (1000x374 of 1242x375), a 10 fps MP4.
ff -framerate 10 -pattern_type glob -i "$kitti/*.png" -vf "hflip,crop=1000:374:121:0" -c:v libx264 -crf 23 \
  -pix_fmt yuv420p -r 10 "$out/kitti_mirrored_crop.mp4"
# 5. Udacity highway rescaled to 800x450 and recompressed hard.
ff -i "$uda" -an -vf "scale=800:450" -c:v libx264 -crf 33 -pix_fmt yuv420p "$out/udacity_800_crf33.mp4"
# 6. Udacity highway mirrored, grayscale.
ff -i "$uda" -an -vf "hflip,format=gray" -c:v libx264 -crf 23 -pix_fmt yuv420p "$out/udacity_mirrored_gray.mp4"

cat > "$out/variants.txt" <<EOF
nuscenes_mirrored.mp4      nuScenes scene-0916 CAM_FRONT keyframes, mirrored, 960x540, 2 fps
nuscenes_crop_640.mp4      nuScenes scene-0916, centre crop 1200x675 rescaled to 640x360, crf 32, 2 fps
kitti_gray_5hz/            KITTI raw 2011_09_26 image_02, every second frame (5 Hz), grayscale PNG
kitti_mirrored_crop.mp4    KITTI raw 2011_09_26 image_02, mirrored, 1000x374 centre crop, 10 fps
udacity_800_crf33.mp4      Udacity highway test_video, 800x450, crf 33, 25 fps
udacity_mirrored_gray.mp4  Udacity highway test_video, mirrored, grayscale, 25 fps
EOF
echo "variants in $out"
