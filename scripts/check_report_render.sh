#!/usr/bin/env bash
# Render a demcal HTML report in headless Chromium and save a full-page screenshot.
#
#   scripts/check_report_render.sh demo-output/report/report.html [screenshot.png]
#
# Needs Debian's `chromium` (apt-get update && apt-get install -y chromium).
# Exits 0 and prints the screenshot path when the page rendered to a non-empty PNG;
# exits 1 if the report is missing or the screenshot is empty, 3 if chromium is absent.
set -euo pipefail
report=${1:?usage: $0 REPORT.html [SCREENSHOT.png]}
shot=${2:-${report%.html}.png}
browser=$(command -v chromium || command -v chromium-browser || command -v google-chrome || true)
if [ -z "$browser" ]; then
  echo "chromium is not installed (apt-get install -y chromium); cannot check rendering." >&2
  exit 3
fi
[ -f "$report" ] || { echo "no report at $report" >&2; exit 1; }
url="file://$(cd "$(dirname "$report")" && pwd)/$(basename "$report")"
rm -f "$shot"
# A tall window so the whole report (tables and embedded figures) lands in the screenshot.
timeout 120 "$browser" --headless --no-sandbox --disable-gpu --disable-background-networking \
  --disable-dev-shm-usage --hide-scrollbars --window-size=1200,${HEIGHT:-6000} \
  --screenshot="$shot" "$url" >/dev/null 2>&1 || true
if [ ! -s "$shot" ]; then
  echo "chromium produced no screenshot of $report" >&2
  exit 1
fi
echo "$shot"
