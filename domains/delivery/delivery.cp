% Legolog's delivery robot in C+ (Levesque and Pagnucco, "Legolog: inexpensive experiments in
% cognitive robotics"): a LEGO robot follows a black line past numbered landmarks, turns
% around, and raises and lowers a tray that carries letters.  The mailroom is landmark 1.
%
% Run it online, on an emulated brick in the world of world.toml, with
%
%     cplus online domains/delivery/delivery.cp
%
% robot.toml beside this file binds the agent's actions to the brick's behaviours, the button
% on the robot to the event `press`, and the landmark number the line follower reports to the
% sensed fluent `atLandmark`.
%
% Which actions are the robot's and which happen to it is the binding file's business, not
% the domain's: all of them are exogenous actions here, free for the planner to choose, and
% the online loop assumes that events do not happen in the future (a plan never counts on a
% button press) but takes them into account when they have been observed.

:- macros
  last -> 4.        % landmarks 1..last along the line

:- sorts
  landmark; direction.

:- objects
  1..last           :: landmark;
  up, down          :: direction.

:- variables
  L, L1             :: landmark;
  D                 :: direction.

:- constants
  atLandmark        :: inertialFluent(landmark);   % sensed: the follower reports it
  facing            :: inertialFluent(direction);  % up: towards higher landmark numbers
  trayUp            :: inertialFluent;             % the robot drives with its tray up
  letter(landmark)  :: inertialFluent;             % a letter for landmark L is on the tray
  % the robot's behaviours
  follow            :: exogenousAction;            % follow the line to the next landmark
  turn              :: exogenousAction;            % turn 180 degrees on the spot
  raiseTray         :: exogenousAction;
  lowerTray         :: exogenousAction;            % hands over the letter for this landmark
  % events
  press             :: exogenousAction;            % the button: a letter for the mailroom
  missed            :: exogenousAction.            % the follower drove past a landmark

% Following the line: to the next landmark, or the one after it when the follower misses one.
follow causes atLandmark=L1 if atLandmark=L & facing=up & -missed where L1 = L+1.
follow causes atLandmark=L1 if atLandmark=L & facing=up & missed where L1 = L+2.
follow causes atLandmark=L1 if atLandmark=L & facing=down & -missed where L1 = L-1.
follow causes atLandmark=L1 if atLandmark=L & facing=down & missed where L1 = L-2.
nonexecutable follow if atLandmark=last & facing=up.
nonexecutable follow if atLandmark=1 & facing=down.
nonexecutable follow if -trayUp.
nonexecutable missed if -follow.
nonexecutable missed if atLandmark=L & facing=up where L+2 > last.
nonexecutable missed if atLandmark=L & facing=down where L-2 < 1.

turn causes facing=down if facing=up.
turn causes facing=up if facing=down.

raiseTray causes trayUp.
nonexecutable raiseTray if trayUp.
lowerTray causes -trayUp.
nonexecutable lowerTray if -trayUp.
lowerTray causes -letter(L) if atLandmark=L.

% Someone put a letter for the mailroom on the tray and pressed the button.
press causes letter(1) if -lowerTray.

% One behaviour at a time.
nonexecutable follow & turn.
nonexecutable follow & raiseTray.
nonexecutable follow & lowerTray.
nonexecutable turn & raiseTray.
nonexecutable turn & lowerTray.
nonexecutable raiseTray & lowerTray.

% Deliver the letter for landmark 3 and come back to the mailroom with nothing on the tray.
:- query
  label :: deliver;
  maxstep :: 0..20;
  0: atLandmark=1 & facing=up & trayUp & letter(3) & [/\L | L\=3 ->> -letter(L)];
  maxstep: atLandmark=1 & [/\L | -letter(L)].
