#!/bin/sh
# Screenshots of the built site in headless Chromium (apt-get install chromium), saved to docs/_static/.
# Run after `make docs` from the repository root; MathJax comes from its CDN unless COORDARM_MATHJAX
# pointed the build at a local tex-chtml.js (then pass --allow-file-access-from-files, as here).
set -e
HTML="$(pwd)/docs/_build/html"
for page in index:landing guide/scenarios:guide_scenarios auto_examples/plot_preset_run:gallery_preset_run \
            reference/scenario-keys:reference_scenario_keys model:model; do
    chromium --headless=new --no-sandbox --disable-gpu --hide-scrollbars --allow-file-access-from-files \
        --window-size=1280,1000 --virtual-time-budget=8000 \
        --screenshot="docs/_static/screenshot_${page#*:}.png" "file://$HTML/${page%%:*}.html"
done
