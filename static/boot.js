// Loads the web app (static/pkg/, built by `cargo xtask`). A file rather than an
// inline script, so the bridge's Content-Security-Policy can forbid inline scripts.
try {
  const app = await import('/pkg/floatball.js');
  await app.default();
  app.start();
} catch (err) {
  console.error(err);
  const note = document.createElement('p');
  note.className = 'load-error';
  note.textContent = 'The app could not be loaded (is it built? run `cargo xtask run`). 应用无法加载。';
  document.body.append(note);
}
