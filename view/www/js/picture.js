// The live picture's markup, the same on the surgeon's display and the assistant's page: the
// render, the B-scan panel (the B-scan, its place on the volume, the B-scans through an
// instrument's tip), the signal banner over them, and the state line beneath. Written once here so
// the two pages cannot drift apart; live-view.js fills it. The pages' own placeholder
// (#page-starting: NO SIGNAL, shown until now and wherever the modules fail to load) goes.
export function buildPicture(container, { interactive = false } = {}) {
  document.getElementById('page-starting')?.remove();
  const renderLabel = interactive
    ? 'Live volume render: drag to orbit, wheel or pinch to zoom'
    : 'Live volume render';
  container.insertAdjacentHTML('afterbegin', `
    <main id="picture" aria-label="Live OCT volume">
      <section id="render-panel">
        <canvas id="render" width="1024" height="768" role="img" aria-label="${renderLabel}"></canvas>
        <div id="instrument-readout" aria-live="polite" hidden></div>
      </section>
      <aside id="bscan-panel">
        <canvas id="bscan" width="512" height="688" role="img" aria-label="Current B-scan"></canvas>
        <canvas id="bscan-locator" width="240" height="160" role="img"
                aria-label="Position of the B-scan in the volume"></canvas>
        <div id="bscan-locator-label">B-scan position unknown</div>
        <canvas id="tip-bscans" width="512" height="688" role="img" hidden
                aria-label="B-scans through the instrument tip: along and across the instrument"></canvas>
      </aside>
      <div id="signal-banner" role="alert" aria-live="assertive">
        <div id="signal-banner-title">NO SIGNAL</div>
        <div id="signal-banner-detail">connecting to the appliance</div>
      </div>
    </main>
    <footer id="state-line" aria-live="polite">Connecting…</footer>`);
}
