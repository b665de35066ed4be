#!/usr/bin/env bash
# Simulated vendor study: three vendors × five units (vendors.csv: per-vendor planted bias, scale,
# bias temperature coefficient and noise; each unit draws its own values around its vendor's with
# the given spread, seeded by the unit number), the same short temperature sweep for every unit,
# then `stend compare` across the 15 runs.
#
#   configs/vendor_study/run.sh [OUT_DIR] [UNITS_PER_VENDOR]
#
# Writes OUT_DIR/units/*.yaml, OUT_DIR/planted.csv (every unit's planted values), the run folders
# (each with temp_poly.json and report.html), OUT_DIR/stend-results.sqlite and the comparison
# report OUT_DIR/compare.html. STEND (default build/bin/stend) selects the program.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
out=${1:-vendor_study_out}
units=${2:-5}
stend=${STEND:-$here/../../build/bin/stend}
mkdir -p "$out/units"
out=$(cd "$out" && pwd)
rm -rf "$out"/runs "$out"/stend-results.sqlite "$out"/planted.csv
cp "$here/temp_poly.yaml" "$out/units/temp_poly.yaml"
echo "vendor,model,serial,run,bias_x,bias_y,bias_z,scale_x,scale_y,scale_z,bias_tc1_x,bias_tc1_y,bias_tc1_z" > "$out/planted.csv"
n=0
tail -n +2 "$here/vendors.csv" | while IFS=, read -r vendor model noise bx by bz sx sy sz tx ty tz bs ss ts; do
  for u in $(seq 1 "$units"); do
    n=$((n + 1))
    serial=$(printf '%s-%03d' "${model%%-*}" "$u")
    seed=$((1000 * u + ${#vendor} * 7 + n))
    # Unit-to-unit spread: Gaussian draws (Box–Muller) from awk, seeded per unit.
    read -r ubx uby ubz usx usy usz utx uty utz < <(awk -v s="$seed" -v bx="$bx" -v by="$by" -v bz="$bz" \
      -v sx="$sx" -v sy="$sy" -v sz="$sz" -v tx="$tx" -v ty="$ty" -v tz="$tz" -v bs="$bs" -v ss="$ss" -v ts="$ts" '
      function gauss() { return sqrt(-2 * log(1 - rand())) * cos(6.283185307179586 * rand()) }
      BEGIN { srand(s);
        printf "%.6g %.6g %.6g %.6g %.6g %.6g %.6g %.6g %.6g\n",
          bx + bs * gauss(), by + bs * gauss(), bz + bs * gauss(),
          sx + ss * gauss(), sy + ss * gauss(), sz + ss * gauss(),
          tx + ts * gauss(), ty + ts * gauss(), tz + ts * gauss() }')
    name="$vendor-$serial"
    sed -e "s/@SEED@/$seed/; s/@VENDOR@/$vendor/; s/@MODEL@/$model/; s/@SERIAL@/$serial/; s/@NOISE@/$noise/" \
        -e "s/@BX@/$ubx/; s/@BY@/$uby/; s/@BZ@/$ubz/; s/@SX@/$usx/; s/@SY@/$usy/; s/@SZ@/$usz/" \
        -e "s/@TX@/$utx/; s/@TY@/$uty/; s/@TZ@/$utz/" "$here/template.yaml" > "$out/units/$name.yaml"
    echo "$vendor,$model,$serial,$name,$ubx,$uby,$ubz,$usx,$usy,$usz,$utx,$uty,$utz" >> "$out/planted.csv"
    STEND_RESULTS_DB="$out/stend-results.sqlite" "$stend" run "$out/units/$name.yaml" -o "$out/runs" --name "$name" -q \
      > "$out/units/$name.log"
    echo "ran $name"
  done
done
"$stend" compare --db "$out/stend-results.sqlite" -o "$out/compare.html"
