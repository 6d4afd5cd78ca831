// Entry of the test page (page.html?engine=three|babylon|spark): loads the engine's classic
// scripts (Babylon.js's UMD builds and the Draco decoder's wrapper), then its page module
// <engine>_page.js, whose default export is the API the tests drive (window.hahaTest).
const SCRIPTS = {
  three: [],
  babylon: ['/node_modules/babylonjs/babylon.js', '/node_modules/babylonjs-loaders/babylonjs.loaders.js',
    '/node_modules/three/examples/jsm/libs/draco/draco_wasm_wrapper.js'],
  spark: [],
};

function loadScript(src) {
  return new Promise((resolve, reject) => {
    const s = document.createElement('script');
    s.src = src;
    s.onload = resolve;
    s.onerror = () => reject(new Error(`${src}: failed to load`));
    document.head.appendChild(s);
  });
}

const engine = new URLSearchParams(location.search).get('engine');
if (!SCRIPTS[engine]) throw new Error(`page.html?engine=${engine}: the engine is three, babylon or spark`);
document.title = `HAHA ${engine} test`;
for (const src of SCRIPTS[engine]) await loadScript(src);
window.hahaTest = (await import(`./${engine}_page.js`)).default;
window.hahaReady = true;
