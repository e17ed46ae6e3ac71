// The notebook side of the viewer (src/view/notebook.cpp, docs/viewer.md). The first view shown
// in a notebook carries this script once: it defines window.trellisNotebook, which holds the page
// template (the viewer's whole script, about 0.6 MB) and opens each view in a sandboxed iframe
// made of that template and the view's data. Every other view carries only its data (in a
// <template>, inert) and calls show(); a view whose output comes before the script's waits
// (data-tv-waiting) and is shown when the script runs.
(() => {
  // The page template before and after the place of the data, put in by notebook.cpp.
  const [HEAD, TAIL] = TRELLIS_PAGE;
  function show(host) {
    if (host.hasAttribute('data-tv-shown')) return;
    host.setAttribute('data-tv-shown', '');
    host.removeAttribute('data-tv-waiting');
    const data = host.querySelector('template').innerHTML;
    const frame = document.createElement('iframe');
    frame.className = 'trellis-view';
    frame.setAttribute('sandbox', 'allow-scripts');
    frame.style.cssText = 'width:100%;height:560px;border:1px solid #ccc;display:block';
    frame.srcdoc = HEAD + data + TAIL;
    const msg = host.querySelector('.tv-nb-msg');
    if (msg) msg.remove();
    host.appendChild(frame);
  }
  window.trellisNotebook = { show };
  for (const host of document.querySelectorAll('.trellis-nb-view[data-tv-waiting]')) show(host);
})();
