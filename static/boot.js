// Loads the web app. A file rather than an inline script, so the bridge's
// Content-Security-Policy can forbid inline scripts. `cargo xtask` builds the app into
// static/pkg/ under content-hashed names and writes the page static/pkg/index.html,
// whose modulepreload link names the app's js (and a preload fetches its wasm); the
// js loads the wasm by its hashed name.
try {
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
