"""The run report: one self-contained HTML file of a run or a comparison (`--report`).

- envelope.py: streaming min/max envelopes per bucket of periods (no extreme lost), fixed memory.
- digest.py: DigestSink, a trace sink that keeps what the report and the PNG draw (envelopes,
  line runs, path vertices) in memory bounded by the program, not by the periods.
- build.py: lays digests, summaries, warnings and the machine file into the page's data.
- page.py: writes the HTML: plotly.js (from the plotly wheel, inlined), the data as one gzip block,
  report.js (the page's linked views and its window.vcncReport API) and report.css.
"""
