// hevo dashboard: what the pages do with JavaScript on. A job page listens to its
// Server-Sent Events stream and updates the state, the progress, each run's line and the
// node's fitness plot (fetched again from the server, which draws it); when a node or the job
// finishes it reloads to show the tables and replays. Each replay gets a robot marker (and one
// for each of a team's other robots, mover, box and item), a cycle slider and a play button.
// Without JavaScript the pages show the same facts, not live.
(function () {
  "use strict";
  var SVG_NS = "http://www.w3.org/2000/svg";

  function sectionOf(node) {
    return document.querySelector('section.node[data-node="' + CSS.escape(node) + '"]');
  }

  function refreshPlot(section) {
    var figure = section.querySelector("figure.fitness");
    if (!figure) return;
    if (figure.dataset.loading === "1") {
      figure.dataset.dirty = "1";
      return;
    }
    figure.dataset.loading = "1";
    fetch(figure.dataset.plot, { credentials: "same-origin", cache: "no-store" })
      .then(function (response) {
        return response.ok ? response.text() : Promise.reject(response.status);
      })
      .then(function (svg) {
        figure.innerHTML = svg;
      })
      .catch(function () {})
      .then(function () {
        figure.dataset.loading = "0";
        if (figure.dataset.dirty === "1") {
          figure.dataset.dirty = "0";
          refreshPlot(section);
        }
      });
  }

  function reloadOnce(source) {
    source.close();
    window.location.reload();
  }

  function setProgress(cell, done, total) {
    cell.textContent = "";
    if (total) {
      var bar = document.createElement("progress");
      bar.max = total;
      bar.value = Math.min(done, total);
      cell.appendChild(bar);
      cell.appendChild(document.createTextNode(" " + Math.min(done, total) + " of " + total + " generations"));
    } else {
      cell.textContent = done + " generations";
    }
  }

  function initJob() {
    var job = document.querySelector(".job[data-events]");
    if (!job || !window.EventSource) return;
    var wasFinished = job.dataset.finished === "1";
    var finishedNodes = {};
    document.querySelectorAll('section.node[data-finished="1"]').forEach(function (s) {
      finishedNodes[s.dataset.node] = true;
    });
    var source = new EventSource(job.dataset.events);
    job.dataset.live = "connecting";
    source.onopen = function () {
      job.dataset.live = "open";
    };
    source.onerror = function () {
      job.dataset.live = "retrying";
    };
    source.addEventListener("job", function (event) {
      var data = JSON.parse(event.data);
      var state = job.querySelector(".job-state");
      if (state) state.textContent = data.state;
      var progress = job.querySelector(".job-progress");
      if (progress) setProgress(progress, data.done, data.total);
      if (data.finished) {
        var cancel = job.querySelector("form.cancel");
        if (cancel) cancel.remove();
        if (!wasFinished) reloadOnce(source);
      }
    });
    source.addEventListener("run", function (event) {
      var data = JSON.parse(event.data);
      var section = sectionOf(data.node);
      if (!section) {
        reloadOnce(source);
        return;
      }
      var list = section.querySelector("ul.runs");
      var item = list.querySelector('li[data-run="' + data.run + '"]');
      if (!item) {
        item = document.createElement("li");
        item.dataset.run = data.run;
        list.appendChild(item);
      }
      if (item.textContent !== data.text) {
        item.textContent = data.text;
        refreshPlot(section);
      }
      var state = section.querySelector(".node-state");
      if (state && state.textContent.indexOf("not started") === 0) {
        state.textContent = state.textContent.replace("not started", "running");
      }
    });
    source.addEventListener("node", function (event) {
      var data = JSON.parse(event.data);
      if (!finishedNodes[data.node]) reloadOnce(source);
    });
    window.addEventListener("pagehide", function () {
      source.close();
    });
  }

  // A robot disc with a nose towards its heading, placed by its transform.
  function robotMarker(className, radius, colour, width) {
    var marker = document.createElementNS(SVG_NS, "g");
    marker.setAttribute("class", className);
    var body = document.createElementNS(SVG_NS, "circle");
    body.setAttribute("r", radius);
    body.setAttribute("fill", "#ffffff");
    body.setAttribute("fill-opacity", "0.6");
    body.setAttribute("stroke", colour);
    body.setAttribute("stroke-width", width);
    var nose = document.createElementNS(SVG_NS, "line");
    nose.setAttribute("x1", "0");
    nose.setAttribute("y1", "0");
    nose.setAttribute("x2", radius * 1.7);
    nose.setAttribute("y2", "0");
    nose.setAttribute("stroke", colour);
    nose.setAttribute("stroke-width", width);
    marker.appendChild(body);
    marker.appendChild(nose);
    return marker;
  }

  // The replay picture's colours: movers blue-grey, boxes brown, items orange (green once
  // delivered, outlined black while carried).
  var MOVER_COLOUR = "#44546a";
  var BOX_COLOUR = "#8c564b";
  var ITEM_COLOURS = { f: "#d55e00", c: "#d55e00", d: "#009e73" };

  // A mover (a diamond), a box (a square) or an item (a small disc) of `track`, drawn apart
  // from the robots' discs with noses; placed by its transform.
  function bodyMarker(track) {
    var marker = document.createElementNS(SVG_NS, "g");
    marker.setAttribute("class", track.kind + "-marker");
    var r = Math.max(track.radius, 3);
    var shape;
    if (track.kind === "item") {
      shape = document.createElementNS(SVG_NS, "circle");
      shape.setAttribute("r", r);
    } else {
      shape = document.createElementNS(SVG_NS, "rect");
      shape.setAttribute("x", -r);
      shape.setAttribute("y", -r);
      shape.setAttribute("width", 2 * r);
      shape.setAttribute("height", 2 * r);
      if (track.kind === "mover") shape.setAttribute("transform", "rotate(45)");
      var colour = track.kind === "mover" ? MOVER_COLOUR : BOX_COLOUR;
      shape.setAttribute("fill", colour);
      shape.setAttribute("fill-opacity", "0.45");
      shape.setAttribute("stroke", colour);
      shape.setAttribute("stroke-width", "2");
    }
    marker.appendChild(shape);
    return marker;
  }

  // Moves a body's marker to entry `cycle` of its track (its last entry after that); an item
  // takes its state's look.
  function placeBody(marker, track, cycle) {
    var at = track.at[Math.min(cycle, track.at.length - 1)];
    marker.setAttribute("transform", "translate(" + at[0] + " " + at[1] + ")");
    if (track.kind !== "item") return;
    var state = track.states.charAt(Math.min(cycle, track.states.length - 1)) || "f";
    var shape = marker.firstChild;
    shape.setAttribute("fill", ITEM_COLOURS[state] || ITEM_COLOURS.f);
    shape.setAttribute("stroke", state === "c" ? "#000000" : "none");
    shape.setAttribute("stroke-width", "1.5");
    marker.dataset.state = state;
  }

  function place(marker, pose) {
    marker.setAttribute("transform", "translate(" + pose[0] + " " + pose[1] + ") rotate(" + pose[2] + ")");
  }

  function initReplay(figure) {
    var poses;
    var teamPoses = [];
    var bodies = [];
    try {
      poses = JSON.parse(figure.dataset.poses);
      if (figure.dataset.teamPoses) teamPoses = JSON.parse(figure.dataset.teamPoses);
      if (figure.dataset.bodies) bodies = JSON.parse(figure.dataset.bodies);
    } catch (e) {
      return;
    }
    var svg = figure.querySelector("svg");
    var controls = figure.querySelector(".replay-controls");
    if (!svg || !controls || !poses.length) return;
    var radius = Math.max(parseFloat(figure.dataset.radius) || 0, 5);
    // The movers', boxes' and items' markers go under the robots'; the other robots' under
    // the robot's, which the replay is about.
    var bodyMarkers = bodies.map(function (track) {
      var trackMarker = bodyMarker(track);
      svg.appendChild(trackMarker);
      return trackMarker;
    });
    var teamMarkers = teamPoses.map(function () {
      var teamMarker = robotMarker("team-marker", radius, "#555555", "1.5");
      svg.appendChild(teamMarker);
      return teamMarker;
    });
    var marker = robotMarker("robot-marker", radius, "#000000", "2.5");
    svg.appendChild(marker);
    controls.hidden = false;
    var slider = controls.querySelector(".cycle-slider");
    var label = controls.querySelector(".cycle-label");
    var play = controls.querySelector(".play");
    var last = poses.length - 1;
    var timer = null;
    function show(cycle) {
      place(marker, poses[cycle]);
      teamMarkers.forEach(function (teamMarker, member) {
        var memberPoses = teamPoses[member];
        if (memberPoses.length) place(teamMarker, memberPoses[Math.min(cycle, memberPoses.length - 1)]);
      });
      bodyMarkers.forEach(function (trackMarker, body) {
        if (bodies[body].at.length) placeBody(trackMarker, bodies[body], cycle);
      });
      marker.dataset.cycle = cycle;
      label.textContent = cycle + " of " + last;
    }
    function stop() {
      if (timer !== null) clearInterval(timer);
      timer = null;
      play.textContent = "Play";
    }
    slider.addEventListener("input", function () {
      stop();
      show(Number(slider.value));
    });
    play.addEventListener("click", function () {
      if (timer !== null) {
        stop();
        return;
      }
      if (Number(slider.value) >= last) slider.value = 0;
      play.textContent = "Pause";
      // 0.1 s cycles shown 10 times faster than real time.
      timer = setInterval(function () {
        var next = Number(slider.value) + 1;
        if (next > last) {
          stop();
          return;
        }
        slider.value = next;
        show(next);
      }, 10);
    });
    show(Number(slider.value));
  }

  document.addEventListener("DOMContentLoaded", function () {
    initJob();
    document.querySelectorAll("figure.replay").forEach(initReplay);
  });
})();
