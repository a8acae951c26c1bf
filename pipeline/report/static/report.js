// pm-design report: a sortable table and zoomable figures, no network access needed.
(function () {
  "use strict";
  // sort the optima table by the clicked column (numbers numerically, text alphabetically)
  document.querySelectorAll("table.sortable").forEach(function (table) {
    table.querySelectorAll("th").forEach(function (th, col) {
      th.addEventListener("click", function () {
        var body = table.tBodies[0];
        var rows = Array.prototype.slice.call(body.rows);
        var up = th.dataset.up !== "1";
        table.querySelectorAll("th").forEach(function (h) { delete h.dataset.up; });
        th.dataset.up = up ? "1" : "0";
        rows.sort(function (a, b) {
          var x = a.cells[col].dataset.value || a.cells[col].textContent;
          var y = b.cells[col].dataset.value || b.cells[col].textContent;
          var nx = parseFloat(x), ny = parseFloat(y);
          var c = (!isNaN(nx) && !isNaN(ny)) ? nx - ny : x.localeCompare(y);
          return up ? c : -c;
        });
        rows.forEach(function (r) { body.appendChild(r); });
      });
    });
  });
  // zoom a figure with the mouse wheel (or a click), pan by dragging, double-click resets
  document.querySelectorAll(".zoom").forEach(function (box) {
    var img = box.querySelector("img"), scale = 1, tx = 0, ty = 0, drag = null;
    function apply() {
      tx = Math.min(0, Math.max(tx, box.clientWidth * (1 - scale)));
      ty = Math.min(0, Math.max(ty, box.clientHeight * (1 - scale)));
      img.style.transform = "translate(" + tx + "px," + ty + "px) scale(" + scale + ")";
      box.classList.toggle("zoomed", scale > 1);
    }
    function zoomAt(x, y, factor) {
      var next = Math.min(8, Math.max(1, scale * factor));
      tx = x - (x - tx) * next / scale; ty = y - (y - ty) * next / scale; scale = next; apply();
    }
    box.addEventListener("wheel", function (e) {
      e.preventDefault();
      var r = box.getBoundingClientRect();
      zoomAt(e.clientX - r.left, e.clientY - r.top, e.deltaY < 0 ? 1.25 : 0.8);
    }, { passive: false });
    box.addEventListener("click", function (e) {
      if (scale === 1) { var r = box.getBoundingClientRect(); zoomAt(e.clientX - r.left, e.clientY - r.top, 2); }
    });
    box.addEventListener("dblclick", function () { scale = 1; tx = 0; ty = 0; apply(); });
    box.addEventListener("pointerdown", function (e) { if (scale > 1) { drag = [e.clientX - tx, e.clientY - ty]; } });
    window.addEventListener("pointerup", function () { drag = null; });
    box.addEventListener("pointermove", function (e) {
      if (drag) { tx = e.clientX - drag[0]; ty = e.clientY - drag[1]; apply(); }
    });
  });
  console.log("pm-design report ready: " + document.querySelectorAll("#optima tbody tr").length + " runs");
  // the page itself never scrolls sideways (wide tables scroll inside their box): checked at 800 px
  console.log("pm-design page width " + document.documentElement.scrollWidth + " of " + window.innerWidth);
}());
