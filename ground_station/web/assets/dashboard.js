// The live dashboard: summary events from the station (server-sent), the rest fetched when
// they say something changed. No page reloads; nothing from outside the station.
'use strict';

const token = new URLSearchParams(location.search).get('token');
const withToken = (path) =>
  token ? path + (path.includes('?') ? '&' : '?') + 'token=' + encodeURIComponent(token) : path;
const $ = (id) => document.getElementById(id);
const seen = {keyframes: {}, analysed: -1, places: -1};
let plotsDue = 0;

async function fetchText(path) {
  const response = await fetch(withToken(path));
  if (!response.ok) throw new Error(path + ': HTTP ' + response.status);
  return response.text();
}

// Server-drawn SVG/HTML; its image links get the token too.
function place(element, html) {
  element.innerHTML = html;
  if (token)
    for (const image of element.querySelectorAll('image'))
      image.setAttribute('href', withToken(image.getAttribute('href')));
}

function megabytes(bytes) { return (bytes / 1e6).toFixed(2) + ' MB'; }
function times(x) { return x > 0 ? x.toFixed(1) + 'x' : 'n/a'; }

// The level a robot sends at, e.g. "q40 at 0.5, 12 reduced".
function sending(r) {
  let text = `q${r.send_quality}`;
  if (r.send_scale < 1) text += ` at ${r.send_scale}`;
  if (r.send_density > 1) text += `, 1 in ${r.send_density}`;
  if (r.keyframes_reduced) text += `, ${r.keyframes_reduced} reduced`;
  if (r.keyframes_thinned) text += `, ${r.keyframes_thinned} held`;
  return text;
}

function showRobots(summary) {
  const body = $('robots').tBodies[0];
  body.replaceChildren();
  for (const r of summary.robots.concat([summary.fleet])) {
    const row = body.insertRow();
    row.dataset.robot = r.robot_id;
    const known = r.has_agent_stats;
    const cells = [r.robot_id, r.keyframes_stored, r.rejected, megabytes(r.bytes_received),
      known ? r.frames_seen : 'n/a', known ? megabytes(r.stream_all_bytes) : 'n/a',
      times(r.saving_vs_stream_all), known ? megabytes(r.vslam_keyframe_bytes) : 'n/a',
      times(r.saving_vs_vslam), r.keyframes_per_minute.toFixed(1),
      r.robot_id === 'FLEET' || !known ? (r.keyframes_reduced ? `${r.keyframes_reduced} reduced` : '')
        : sending(r), known && r.link_bytes_per_s > 0 ? `${(r.link_bytes_per_s / 1e3).toFixed(1)} kB/s` : ''];
    const names = ['robot', 'stored'];
    cells.forEach((text, i) => {
      const cell = row.insertCell();
      cell.textContent = text;
      if (names[i]) cell.className = names[i];
    });
  }
}

function showQueue(summary) {
  const a = summary.analysis;
  const live = (n) => (n === null ? '&ndash;' : n);
  $('queue').innerHTML = `waiting <b id="q-waiting">${live(a.waiting)}</b> &middot; running ` +
    `<b>${live(a.running)}</b> &middot; analysed <b id="q-done">${a.done}</b> &middot; deferred ` +
    `<b id="q-deferred">${a.deferred}</b> &middot; failed <b id="q-failed">${a.failed}</b> ` +
    `&middot; not yet analysed <b>${a.unanalysed}</b> &middot; place matches ` +
    `<b>${summary.place_matches}</b>`;
}

function strip(robot) {
  let element = document.querySelector(`.strip[data-robot="${CSS.escape(robot)}"]`);
  if (!element) {
    const title = document.createElement('h3');
    title.textContent = robot;
    element = document.createElement('div');
    element.className = 'strip';
    element.dataset.robot = robot;
    $('strips').append(title, element);
  }
  return element;
}

async function refreshStrip(robot) {
  const data = JSON.parse(await fetchText('api/keyframes?robot=' + encodeURIComponent(robot)));
  place(strip(robot), data.keyframes.map((k) => k.figure).join(''));
}

async function refreshPlots() {
  place($('bandwidth'), await fetchText('api/bandwidth.svg'));
  place($('map'), await fetchText('api/map.svg'));
}

async function onSummary(summary) {
  const status = $('status');
  status.textContent = summary.live ? 'live' : 'finished run';
  status.className = 'status ' + (summary.live ? 'live' : 'finished');
  showRobots(summary);
  showQueue(summary);
  const analysedChanged = summary.analysis.done + summary.analysis.failed !== seen.analysed;
  const changed = [];
  for (const r of summary.robots) {
    if (analysedChanged || seen.keyframes[r.robot_id] !== r.keyframes_stored) changed.push(r.robot_id);
    seen.keyframes[r.robot_id] = r.keyframes_stored;
  }
  const plotsChanged = changed.length > 0 || summary.place_matches !== seen.places;
  seen.analysed = summary.analysis.done + summary.analysis.failed;
  seen.places = summary.place_matches;
  await Promise.all(changed.map(refreshStrip));
  // The plots are redrawn at most every two seconds while keyframes arrive.
  if (plotsChanged && Date.now() >= plotsDue) {
    plotsDue = Date.now() + 2000;
    await refreshPlots();
  }
}

async function search(event) {
  event.preventDefault();
  const query = $('search-text').value.trim();
  const out = $('search-results');
  if (!query) return;
  const response = await fetch(withToken('api/search?q=' + encodeURIComponent(query)));
  const data = await response.json();
  out.replaceChildren();
  if (!response.ok) {
    out.innerHTML = `<p class="error"></p>`;
    out.firstChild.textContent = data.error;
    return;
  }
  if (data.results.length === 0) out.textContent = 'no keyframe shows "' + query + '"';
  for (const w of data.results) {
    const line = document.createElement('p');
    line.className = 'hit';
    line.dataset.key = w.robot_id + '#' + w.sequence;
    line.textContent = `${w.robot_id}#${w.sequence}: ${w.text} (${w.confidence.toFixed(2)})`;
    out.append(line);
  }
}

function connect() {
  const events = new EventSource(withToken('api/events'));
  let busy = Promise.resolve();
  events.addEventListener('summary', (event) => {
    const summary = JSON.parse(event.data);
    busy = busy.then(() => onSummary(summary)).catch((e) => console.warn(e));
  });
  // EventSource reconnects by itself; the page says so meanwhile.
  events.onerror = () => {
    $('status').textContent = 'reconnecting…';
    $('status').className = 'status lost';
  };
}

$('search').addEventListener('submit', search);
connect();
