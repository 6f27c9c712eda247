// Mucosa realism study page. The server is the source of truth: every screen
// comes from /api/state or the reply to an answer, so a reload or a server
// restart resumes exactly where the observer was. An answer not yet
// acknowledged is kept in localStorage and sent again until it is.
// Each observer has a secret link, /?t=TOKEN: the token goes with every API
// call (Authorization: Bearer) and image (?t=); the server binds it to one
// observer id, so without it nothing can be read or answered.
'use strict';
(() => {
  const TOKEN = new URLSearchParams(location.search).get('t') || '';
  const PENDING = 'mucosa-study-pending:' + TOKEN;
  const $ = (id) => document.getElementById(id);
  let state = null;        // last state from the server
  let busy = false;        // an answer is in flight: input is ignored
  let ready = false;       // the current screen's images have loaded
  let shownAt = null;      // when the current screen became answerable (ms)
  let breakSeen = -1;      // trial index whose series-break screen was dismissed
  let current = 'welcome';

  function show(name) {
    current = name;
    for (const s of document.querySelectorAll('.screen')) s.hidden = s.id !== 'screen-' + name;
  }
  function message(text) { const m = $('message'); m.textContent = text || ''; m.hidden = !text; }
  function setButtons(enabled) {
    for (const b of document.querySelectorAll('.screen button')) b.disabled = !enabled;
  }

  const withToken = (url) => `${url}?t=${encodeURIComponent(TOKEN)}`;
  function invalidLink() {
    show('invalid');
    $('progress').textContent = '';
    message('');
  }

  async function call(method, url, body) {
    const headers = { Authorization: `Bearer ${TOKEN}` };
    if (body) headers['Content-Type'] = 'application/json';
    const res = await fetch(url, {
      method, cache: 'no-store', headers,
      body: body ? JSON.stringify(body) : undefined,
    });
    let data = null;
    try { data = await res.json(); } catch (e) { data = null; }
    return { status: res.status, data };
  }

  function loadImages(pairs) {  // [[img element, url]] -> resolves when all have loaded
    return Promise.all(pairs.map(([img, plain]) => new Promise((resolve) => {
      const url = withToken(plain);
      if (img.getAttribute('src') === url && img.complete && img.naturalWidth) return resolve();
      img.onload = () => resolve();
      img.onerror = () => { message('An image failed to load; reload the page.'); resolve(); };
      img.src = url;
    })));
  }

  function progress(s) {
    $('progress').textContent = s.done ? 'Complete' : `Screen ${s.trial + 1} of ${s.total}`;
    $('bar-fill').style.width = `${(100 * s.trial) / s.total}%`;
  }

  async function render(s) {
    state = s;
    progress(s);
    // A button keeps focus after a click; Enter or Space would then answer the
    // next screen by accident.
    if (document.activeElement && document.activeElement !== document.body) document.activeElement.blur();
    if (s.done) { show('done'); return; }
    const sc = s.screen;
    ready = false;
    setButtons(false);
    let images = [];
    if (sc.kind === 'calibration') {
      show('calibration');
      images = [[$('cal-left'), sc.left], [$('cal-right'), sc.right]];
    } else if (sc.kind === 'likert') {
      if (sc.series_start && breakSeen !== s.trial) {
        $('break-done').textContent = `${sc.series} of ${sc.series_count}`;
        show('break');
        setButtons(true);
        return;
      }
      show('likert');
      $('progress').textContent = `Image ${sc.index + 1} of ${sc.count} (series ${sc.series + 1} of ${sc.series_count})`;
      images = [[$('likert-image'), sc.image]];
    } else {
      show('twoafc');
      $('progress').textContent = `Pair ${sc.index + 1} of ${sc.count}`;
      images = [[$('afc-left'), sc.left], [$('afc-right'), sc.right]];
    }
    await loadImages(images);
    if (state !== s) return;  // a newer state arrived meanwhile
    for (const url of s.preload || []) { const im = new Image(); im.src = withToken(url); }
    shownAt = Date.now();
    ready = true;
    setButtons(true);
  }

  async function sendPending() {
    const raw = localStorage.getItem(PENDING);
    if (!raw) return null;
    const body = JSON.parse(raw);
    for (let attempt = 0; ; attempt++) {
      let r;
      try { r = await call('POST', '/api/answer', body); } catch (e) { r = { status: 0, data: null }; }
      if (r.status === 401) { localStorage.removeItem(PENDING); invalidLink(); return null; }
      if (r.status === 200 || r.status === 409 || r.status === 400 || r.status === 404) {
        localStorage.removeItem(PENDING);
        if (r.status === 200) { message(''); return r.data; }
        if (r.status === 400 || r.status === 404) message(r.data && r.data.error || 'answer refused');
        return null;  // 409: answered before; the caller re-reads the state
      }
      message('Saving your answer... (the server is not reachable, retrying)');
      await new Promise((res) => setTimeout(res, Math.min(5000, 300 * 2 ** attempt)));
    }
  }

  // Where this link stands: not yet started (the welcome form), or its screen.
  async function refresh() {
    for (let attempt = 0; ; attempt++) {
      let r;
      try { r = await call('GET', '/api/state'); } catch (e) { r = { status: 0, data: null }; }
      if (r.status === 401) return invalidLink();
      if (r.status === 200 && r.data && r.data.registered === false) { message(''); show('welcome'); return; }
      if (r.status === 200) { message(''); return render(r.data); }
      if (r.status >= 400 && r.status < 500) return message(r.data && r.data.error || 'could not start');
      message('Connecting to the study server... retrying');
      await new Promise((res) => setTimeout(res, Math.min(5000, 300 * 2 ** attempt)));
    }
  }

  async function start(observer, group) {
    for (let attempt = 0; ; attempt++) {
      let r;
      try { r = await call('POST', '/api/session', { observer, group }); } catch (e) { r = { status: 0, data: null }; }
      if (r.status === 200) { message(''); return render(r.data); }
      if (r.status === 401) return message('This id belongs to another link; enter your own id.');
      if (r.status >= 400 && r.status < 500) return message(r.data && r.data.error || 'could not start');
      message('Connecting to the study server... retrying');
      await new Promise((res) => setTimeout(res, Math.min(5000, 300 * 2 ** attempt)));
    }
  }

  async function answer(value) {
    if (busy || !state || state.done) return;
    if (current !== 'break' && !ready) return;
    busy = true;
    setButtons(false);
    const body = {
      observer: state.observer, trial: state.trial, answer: value,
      shown_at_ms: shownAt, answered_at_ms: Date.now(),
    };
    localStorage.setItem(PENDING, JSON.stringify(body));
    try {
      const next = await sendPending();
      if (next) await render(next); else await refresh();
    } finally {
      busy = false;
      if (ready || current === 'break' || current === 'welcome') setButtons(true);
    }
  }

  function continueBreak() {
    if (current !== 'break' || !state) return;
    breakSeen = state.trial;
    render(state);
  }

  $('welcome-form').addEventListener('submit', async (e) => {
    e.preventDefault();
    const observer = $('observer').value.trim();
    const g = document.querySelector('input[name=group]:checked');
    if (!observer || !g) return message('Enter your id and choose a group.');
    await start(observer, g.value);
  });
  $('cal-continue').addEventListener('click', () => answer('seen'));
  $('break-continue').addEventListener('click', continueBreak);
  for (const b of document.querySelectorAll('[data-score]'))
    b.addEventListener('click', () => answer(Number(b.dataset.score)));
  $('choose-left').addEventListener('click', () => answer('left'));
  $('choose-right').addEventListener('click', () => answer('right'));

  document.addEventListener('keydown', (e) => {
    if (e.repeat || e.altKey || e.ctrlKey || e.metaKey) return;
    if (current === 'likert' && e.key >= '1' && e.key <= '5') { e.preventDefault(); answer(Number(e.key)); }
    else if (current === 'twoafc' && e.key === 'ArrowLeft') { e.preventDefault(); answer('left'); }
    else if (current === 'twoafc' && e.key === 'ArrowRight') { e.preventDefault(); answer('right'); }
    else if (current === 'calibration' && (e.key === 'Enter' || e.key === ' ')) { e.preventDefault(); answer('seen'); }
    else if (current === 'break' && (e.key === 'Enter' || e.key === ' ')) { e.preventDefault(); continueBreak(); }
  });

  (async () => {
    if (!/^[0-9a-f]{32}$/.test(TOKEN)) return invalidLink();
    const pendingState = await sendPending().catch(() => null);
    if (pendingState) return render(pendingState);
    return refresh();
  })();
})();
