// Loads the web app. A file rather than an inline script, so the bridge's
// Content-Security-Policy can forbid inline scripts. `cargo xtask` builds the app into
// static/pkg/ under content-hashed names and writes the page static/pkg/index.html,
// whose modulepreload link names the app's js (and a preload fetches its wasm); the
// js loads the wasm by its hashed name.
//
// The pages an operator rarely opens (Create, Commissioning, Installation) are in
// wasm chunks the app fetches when they are opened (web/src/lazy.rs). The page's
// `<meta name="floatball-chunks" content="create=/pkg/a.wasm /pkg/b.wasm;…">` names
// each one's chunks: opened at such a page (a reload on #/create), their download
// starts now, beside the app's, rather than after it.
try {
  const chunks = document.querySelector('meta[name="floatball-chunks"]');
  const opened = location.hash.replace(/^#\/?/, '');
  for (const entry of (chunks?.content ?? '').split(';')) {
    const [page, files] = entry.split('=');
    if (page === opened && files) {
      for (const href of files.split(' ')) {
        const preload = document.createElement('link');
        preload.rel = 'preload';
        preload.as = 'fetch';
        preload.type = 'application/wasm';
        preload.crossOrigin = 'anonymous';
        preload.href = href;
        document.head.append(preload);
      }
    }
  }
  const link = document.querySelector('link[rel="modulepreload"]');
  if (!link) {
    throw new Error('no app in the page: static/pkg/index.html is not built');
  }
  const app = await import(link.href);
  await app.default();
  app.start();
} catch (err) {
  console.error(err);
  const note = document.createElement('p');
  note.className = 'load-error';
  note.textContent = 'The app could not be loaded (is it built? run `cargo xtask run`). 应用无法加载。';
  document.body.append(note);
}
