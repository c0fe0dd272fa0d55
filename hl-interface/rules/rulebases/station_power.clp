;;; station_power.clp — the station's energy scheduler of seed §4.2 (robosim study station
;;; --scheduler on; docs/rules.md, docs/studies.md).
;;;
;;; "A higher-level controller of this subsystem must predict the future energy production
;;; (interactions with attitude control and other orbital operations!), and based on the
;;; reserve energy and projected production must schedule the operation of the different
;;; consumers." Every study step the study retracts its facts (templates sp-*) and asserts them
;;; afresh: the time, the battery, the predicted generation per orbit phase over the coming
;;; orbit, every consumer with its priority, mode and demand, the experiments, the predicted
;;; desaturation windows and the docking events, and the ECLSS faults; then (sp-need-plan).
;;; The rules predict the battery's lowest energy over the horizon with the plan's load
;;; (sp-plan) and change the plan one decision at a time, each predicted again:
;;;   * short of the reserve: hygiene deferred, then running experiments stopped, then the
;;;     experiment modules' air control reduced — never the crew modules' (seed §4.2); if even
;;;     that is short, the vital shortfall is said (the station's operations must be
;;;     rescheduled);
;;;   * with room above the reserve and a margin: the experiment modules' air control back to
;;;     full, then hygiene, then experiments started;
;;;   * a microgravity-sensitive experiment is never started into a desaturation window or a
;;;     docking event (seed §4.2 constraints 1 and 2): it is moved after the window; one running
;;;     when a window opens is stopped and moved.
;;; Every decision is a call (robosim decide|set-mode|start|stop|move RULE TARGET … REASON):
;;; the study applies it and records it with the rule's name and reason.

(deftemplate sp-now (slot t) (slot step) (slot reserve-kwh) (slot margin-kwh))
(deftemplate sp-battery (slot energy-kwh) (slot capacity-kwh) (slot charge-eff)
  (slot discharge-eff))
;;; predicted generation over one orbit phase (sunlit or eclipse), in time order
(deftemplate sp-phase (slot kind) (slot start) (slot end) (slot power-kw))
(deftemplate sp-consumer (slot name) (slot priority) (slot mode) (slot full-kw)
  (slot reduced-kw))
;;; state: waiting (asked for, not running) | running; not-before: s
(deftemplate sp-experiment (slot name) (slot power-kw) (slot remaining-s) (slot sensitive)
  (slot state) (slot not-before) (slot deferred (default no)))
;;; kind: desaturation | docking
(deftemplate sp-window (slot kind) (slot start) (slot end))
;;; an ECLSS fault as the study's plant has it: state failed | isolated | spare-online
(deftemplate sp-fault (slot consumer) (slot component) (slot state) (slot demand-kw))
(deftemplate sp-plan (slot load-kw) (slot min-kwh))
(deftemplate sp-need-plan)

;;; ---------------------------------------------------------------- prediction

(deffunction sp-demand (?mode ?full ?reduced)
  (if (eq ?mode full) then ?full else (if (eq ?mode reduced) then ?reduced else 0.0)))

;;; The plan's base load, kW: every consumer in its mode (the running experiments are added
;;; by sp-min-energy, each until its run ends).
(deffunction sp-load ()
  (bind ?l 0.0)
  (do-for-all-facts ((?c sp-consumer)) TRUE
    (bind ?l (+ ?l (sp-demand ?c:mode ?c:full-kw ?c:reduced-kw))))
  ?l)

;;; The store after ?h hours at a net power ?net kW (charged at ?ec up to ?cap, drawn at 1/?ed).
(deffunction sp-charge (?e ?cap ?ec ?ed ?net ?h)
  (if (>= ?net 0.0)
    then (min ?cap (+ ?e (* ?net ?ec ?h)))
    else (+ ?e (/ (* ?net ?h) ?ed))))

;;; The load at time ?t, kW: ?base, plus ?extra from ?from until ?until, plus every running
;;; experiment before its run ends (?now + its time left).
(deffunction sp-load-at (?base ?extra ?from ?until ?now ?t)
  (bind ?l ?base)
  (if (and (>= ?t ?from) (< ?t ?until)) then (bind ?l (+ ?l ?extra)))
  (do-for-all-facts ((?x sp-experiment))
      (and (eq ?x:state running) (< ?t (+ ?now ?x:remaining-s)))
    (bind ?l (+ ?l ?x:power-kw)))
  ?l)

;;; The lowest stored energy (kWh) over the phases with the base load ?base kW, plus ?extra kW
;;; from ?from until ?until (a candidate experiment), plus the running experiments until they
;;; end. Below 0: that much demand would go unserved. Exact over the pieces where the load is
;;; constant (the phases cut at every run's end, ?from and ?until).
(deffunction sp-min-energy-from (?base ?extra ?from ?until)
  (bind ?e 0.0) (bind ?cap 0.0) (bind ?ec 1.0) (bind ?ed 1.0) (bind ?now 0.0)
  (do-for-fact ((?b sp-battery)) TRUE
    (bind ?e ?b:energy-kwh) (bind ?cap ?b:capacity-kwh)
    (bind ?ec ?b:charge-eff) (bind ?ed ?b:discharge-eff))
  (do-for-fact ((?n sp-now)) TRUE (bind ?now ?n:t))
  (bind ?cuts (create$ ?from ?until))
  (do-for-all-facts ((?x sp-experiment)) (eq ?x:state running)
    (bind ?cuts (create$ ?cuts (+ ?now ?x:remaining-s))))
  (bind ?min ?e)
  (do-for-all-facts ((?p sp-phase)) TRUE
    (bind ?pts (create$ ?p:start ?p:end))
    (progn$ (?c ?cuts)
      (if (and (> ?c ?p:start) (< ?c ?p:end)) then (bind ?pts (create$ ?pts ?c))))
    (bind ?pts (sort > ?pts))
    (loop-for-count (?i 1 (- (length$ ?pts) 1))
      (bind ?a (nth$ ?i ?pts))
      (bind ?z (nth$ (+ ?i 1) ?pts))
      (bind ?e (sp-charge ?e ?cap ?ec ?ed
                          (- ?p:power-kw (sp-load-at ?base ?extra ?from ?until ?now ?a))
                          (/ (- ?z ?a) 3600.0)))
      (if (< ?e ?min) then (bind ?min ?e))))
  ?min)

;;; The same with the extra load from now (the first phase's start).
(deffunction sp-min-energy (?base ?extra ?until)
  (bind ?from 0.0)
  (do-for-fact ((?n sp-now)) TRUE (bind ?from ?n:t))
  (sp-min-energy-from ?base ?extra ?from ?until))

;;; The start of the first sunlit phase after ?t (0 if none in the horizon).
(deffunction sp-next-sunrise (?t)
  (bind ?s 0.0)
  (do-for-all-facts ((?p sp-phase)) (and (eq ?p:kind sunlit) (> ?p:start ?t))
    (if (or (= ?s 0.0) (< ?p:start ?s)) then (bind ?s ?p:start)))
  ?s)

;;; Whether [?a, ?b] meets a desaturation window or a docking event; its end if so, else 0.
(deffunction sp-window-end (?a ?b)
  (bind ?end 0.0)
  (do-for-all-facts ((?w sp-window)) (and (< ?w:start ?b) (> ?w:end ?a))
    (bind ?end (max ?end ?w:end)))
  ?end)

(deffunction sp-replan (?plan)
  (retract ?plan)
  (assert (sp-need-plan)))

(defrule sp-predict
  (declare (salience 100))
  ?n <- (sp-need-plan)
  =>
  (retract ?n)
  (do-for-all-facts ((?p sp-plan)) TRUE (retract ?p))
  (bind ?l (sp-load))
  (assert (sp-plan (load-kw ?l) (min-kwh (sp-min-energy ?l 0.0 0.0)))))

;;; ---------------------------------------------------------------- faults (seed §4.3)

;;; A diagnosed ECLSS fault changes a consumer's demand (the study's plant: the failed unit's
;;; process stands still until its spare is on line, then catches up); the plan is predicted
;;; with the new demand — said once per state.
(defrule sp-fault-reaction
  (declare (salience 90))
  (sp-fault (consumer ?c) (component ?k) (state ?s) (demand-kw ?d))
  (sp-plan (load-kw ?l) (min-kwh ?m))
  =>
  (robosim decide sp-fault-reaction ?c ?s
    (str-cat ?k " " ?s ": " ?c " now draws " ?d " kW; plan load " ?l
             " kW, predicted minimum " ?m " kWh")))

;;; ---------------------------------------------------------------- shedding

(defrule sp-stop-experiment-for-window
  (declare (salience 80))
  (sp-now (t ?t) (step ?dt))
  ?x <- (sp-experiment (name ?n) (state running) (sensitive yes) (remaining-s ?r))
  (sp-window (kind ?k) (start ?a&:(<= ?a (+ ?t ?dt))) (end ?b&:(> ?b ?t)))
  ?p <- (sp-plan)
  =>
  (modify ?x (state waiting) (not-before ?b))
  (robosim stop sp-stop-experiment-for-window ?n ?b
    (str-cat "a " ?k " window " ?a "-" ?b " s opens: the microgravity run is stopped ("
             ?r " s left) and moved after it"))
  (sp-replan ?p))

(defrule sp-defer-hygiene
  (declare (salience 50))
  (sp-now (reserve-kwh ?r))
  ?p <- (sp-plan (min-kwh ?m&:(< ?m ?r)))
  ?c <- (sp-consumer (name ?n) (priority sheddable) (mode full|reduced))
  =>
  (modify ?c (mode off))
  (robosim set-mode sp-defer-hygiene ?n off
    (str-cat "predicted minimum " ?m " kWh < reserve " ?r " kWh over the coming orbit"))
  (sp-replan ?p))

(defrule sp-stop-experiment-for-energy
  (declare (salience 49))
  (sp-now (t ?t) (reserve-kwh ?r))
  ?p <- (sp-plan (min-kwh ?m&:(< ?m ?r)))
  (not (sp-consumer (priority sheddable) (mode full|reduced)))
  ?x <- (sp-experiment (name ?n) (state running) (power-kw ?w))
  (not (sp-experiment (state running) (power-kw ?w2&:(> ?w2 ?w))))
  =>
  (modify ?x (state waiting) (not-before ?t))
  (robosim stop sp-stop-experiment-for-energy ?n ?t
    (str-cat "predicted minimum " ?m " kWh < reserve " ?r " kWh: the largest running experiment ("
             ?w " kW) is stopped"))
  (sp-replan ?p))

;;; Seed §4.2: "the air control subsystems for the experiment modules might operate at a
;;; reduced capacity, while it is not true for the crew modules" — after the experiments that
;;; need it are stopped.
(defrule sp-reduce-experiment-air
  (declare (salience 48))
  (sp-now (reserve-kwh ?r))
  ?p <- (sp-plan (min-kwh ?m&:(< ?m ?r)))
  (not (sp-consumer (priority sheddable) (mode full|reduced)))
  (not (sp-experiment (state running)))
  ?c <- (sp-consumer (name ?n) (priority reducible) (mode full))
  =>
  (modify ?c (mode reduced))
  (robosim set-mode sp-reduce-experiment-air ?n reduced
    (str-cat "predicted minimum " ?m " kWh < reserve " ?r
             " kWh with hygiene deferred and no experiment running: experiment modules' air control reduced (crew modules' kept)"))
  (sp-replan ?p))

(defrule sp-vital-shortfall
  (declare (salience 47))
  (sp-now (reserve-kwh ?r))
  (sp-plan (load-kw ?l) (min-kwh ?m&:(< ?m ?r)))
  (not (sp-consumer (priority sheddable|reducible) (mode full)))
  (not (sp-consumer (priority sheddable) (mode reduced)))
  (not (sp-experiment (state running)))
  =>
  (robosim decide sp-vital-shortfall station short
    (str-cat "only vital loads left (" ?l " kW) and the predicted minimum is " ?m
             " kWh < reserve " ?r " kWh: the station's operations must be rescheduled (seed 4.2)")))

;;; ---------------------------------------------------------------- restoring

(defrule sp-restore-experiment-air
  (declare (salience 30))
  (sp-now (reserve-kwh ?r) (margin-kwh ?g))
  ?p <- (sp-plan (load-kw ?l) (min-kwh ?m&:(>= ?m ?r)))
  ?c <- (sp-consumer (name ?n) (priority reducible) (mode reduced) (full-kw ?f) (reduced-kw ?d))
  (test (>= (sp-min-energy (+ ?l (- ?f ?d)) 0.0 0.0) (+ ?r ?g)))
  =>
  (modify ?c (mode full))
  (robosim set-mode sp-restore-experiment-air ?n full
    (str-cat "predicted minimum at full capacity " (sp-min-energy (+ ?l (- ?f ?d)) 0.0 0.0)
             " kWh >= reserve + margin " (+ ?r ?g) " kWh"))
  (sp-replan ?p))

(defrule sp-restore-sheddable
  (declare (salience 29))
  (sp-now (reserve-kwh ?r) (margin-kwh ?g))
  ?p <- (sp-plan (load-kw ?l) (min-kwh ?m&:(>= ?m ?r)))
  (not (sp-consumer (priority reducible) (mode reduced|off)))
  ?c <- (sp-consumer (name ?n) (priority sheddable) (mode off) (full-kw ?f))
  (test (>= (sp-min-energy (+ ?l ?f) 0.0 0.0) (+ ?r ?g)))
  =>
  (modify ?c (mode full))
  (robosim set-mode sp-restore-sheddable ?n full
    (str-cat "predicted minimum with it " (sp-min-energy (+ ?l ?f) 0.0 0.0)
             " kWh >= reserve + margin " (+ ?r ?g) " kWh"))
  (sp-replan ?p))

;;; ---------------------------------------------------------------- experiments

;;; Constraints 1-2 of seed §4.2: a microgravity run is not started into a desaturation or a
;;; docking: it is moved after the window (again, while it meets one).
(defrule sp-move-experiment
  (declare (salience 40))
  (sp-now (t ?t))
  ;; matched after the plan is made, so that every window of the pass is asserted when the
  ;; test below is evaluated (a test CE is evaluated once, when the patterns before it match)
  (sp-plan)
  ?x <- (sp-experiment (name ?n) (state waiting) (sensitive yes) (remaining-s ?d)
                       (not-before ?nb))
  (test (> (sp-window-end (max ?t ?nb) (+ (max ?t ?nb) ?d)) 0.0))
  =>
  (bind ?a (max ?t ?nb))
  (bind ?b (sp-window-end ?a (+ ?a ?d)))
  (modify ?x (not-before ?b))
  (robosim move sp-move-experiment ?n ?b
    (str-cat "its run " ?a "-" (+ ?a ?d) " s would meet a desaturation or docking window ending at "
             ?b " s: moved after it")))

(defrule sp-start-experiment
  (declare (salience 20))
  (sp-now (t ?t) (reserve-kwh ?r) (margin-kwh ?g))
  ?p <- (sp-plan (load-kw ?l) (min-kwh ?m&:(>= ?m ?r)))
  (not (sp-consumer (priority reducible|sheddable) (mode reduced|off)))
  ?x <- (sp-experiment (name ?n) (state waiting) (power-kw ?w) (remaining-s ?d)
                       (sensitive ?s) (not-before ?nb&:(<= ?nb ?t)))
  (test (or (eq ?s no) (= (sp-window-end ?t (+ ?t ?d)) 0.0)))
  (test (>= (sp-min-energy ?l ?w (+ ?t ?d)) (+ ?r ?g)))
  =>
  (bind ?with (sp-min-energy ?l ?w (+ ?t ?d)))
  (modify ?x (state running))
  (robosim start sp-start-experiment ?n ?t
    (str-cat "predicted minimum with it " ?with " kWh >= reserve + margin "
             (+ ?r ?g) " kWh; no window in " ?t "-" (+ ?t ?d) " s"))
  (sp-replan ?p))

;;; Seed §4.2: "based on the reserve energy and projected production must schedule the
;;; operation of the different consumers" — a run that does not fit now but fits from the next
;;; sunrise (clear of windows when sensitive) is moved there.
(defrule sp-move-experiment-to-sunrise
  (declare (salience 15))
  (sp-now (t ?t) (reserve-kwh ?r) (margin-kwh ?g))
  (sp-plan (load-kw ?l))
  ?x <- (sp-experiment (name ?n) (state waiting) (power-kw ?w) (remaining-s ?d)
                       (sensitive ?s) (not-before ?nb&:(<= ?nb ?t)))
  (test (> (sp-next-sunrise ?t) ?t))
  (test (or (eq ?s no)
            (= (sp-window-end (sp-next-sunrise ?t) (+ (sp-next-sunrise ?t) ?d)) 0.0)))
  (test (>= (sp-min-energy-from ?l ?w (sp-next-sunrise ?t) (+ (sp-next-sunrise ?t) ?d))
            (+ ?r ?g)))
  =>
  (bind ?at (sp-next-sunrise ?t))
  (modify ?x (not-before ?at))
  (robosim move sp-move-experiment-to-sunrise ?n ?at
    (str-cat "does not fit now (predicted minimum with it " (sp-min-energy ?l ?w (+ ?t ?d))
             " kWh) but from the next sunrise at " ?at " s it does ("
             (sp-min-energy-from ?l ?w ?at (+ ?at ?d)) " kWh >= reserve + margin " (+ ?r ?g)
             " kWh): moved there")))

;;; Said once per run asked for: an experiment waiting because the energy is short.
(defrule sp-defer-experiment
  (declare (salience 10))
  (sp-now (t ?t) (reserve-kwh ?r) (margin-kwh ?g))
  (sp-plan (load-kw ?l))
  ?x <- (sp-experiment (name ?n) (state waiting) (power-kw ?w) (remaining-s ?d)
                       (not-before ?nb&:(<= ?nb ?t)) (deferred no))
  =>
  (modify ?x (deferred yes))
  (robosim defer sp-defer-experiment ?n ?t
    (str-cat "not started: predicted minimum with it " (sp-min-energy ?l ?w (+ ?t ?d))
             " kWh against reserve + margin " (+ ?r ?g)
             " kWh, or a consumer is still shed")))

(defrule sp-report-errors
  (robosim-error (command ?c) (message ?m))
  =>
  (printout t "station_power: (robosim " ?c ") failed: " ?m crlf))
